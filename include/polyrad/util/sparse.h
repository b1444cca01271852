// Compressed sparse rows, the storage of every operator polyrad builds.
//
// Rows are contiguous runs of (column, value) pairs in column order. Value is a scalar (float)
// for geometric weights and an RGB triple for the camera gather.
//
//   Csr<float> f = ...;
//   for (auto k = f.start[i]; k < f.start[i + 1]; ++k) use(f.column[k], f.value[k]);
//
// Memory: 4 bytes per column index plus sizeof(V) per value, plus 8 bytes per row.
#pragma once

#include <cstdint>
#include <vector>

namespace polyrad {

template <typename V>
struct Csr {
  std::int64_t rows = 0, cols = 0;
  std::vector<std::int64_t> start{0};  // rows + 1 entries
  std::vector<std::int32_t> column;
  std::vector<V> value;

  std::int64_t nnz() const { return static_cast<std::int64_t>(column.size()); }
  std::size_t bytes() const {
    return start.size() * sizeof(std::int64_t) + column.size() * sizeof(std::int32_t) +
           value.size() * sizeof(V);
  }
  // Appends one row from (column, value) pairs already in column order.
  void push_row() {
    ++rows;
    start.push_back(static_cast<std::int64_t>(column.size()));
  }
  // Value at (r, c) or V{} (binary search in the row).
  V at(std::int64_t r, std::int32_t c) const {
    std::int64_t lo = start[r], hi = start[r + 1];
    while (lo < hi) {
      std::int64_t mid = (lo + hi) / 2;
      if (column[mid] < c) lo = mid + 1;
      else hi = mid;
    }
    return (lo < start[r + 1] && column[lo] == c) ? value[lo] : V{};
  }
};

}  // namespace polyrad
