// Compressed sparse rows, the storage of every operator polyrad builds, and their products.
//
// Rows are contiguous runs of (column, value) pairs in column order. Value is a scalar (float)
// for geometric weights and an RGB triple for the camera gather. The operand of a product holds
// `width` doubles per column index, row-major (a Field: 3; a block of C fields: 3 C); a scalar
// value scales all of them, an RGB value scales value j % 3 by channel j % 3.
//
//   Csr<float> f = ...;
//   for (auto [column, value] : f.row(i)) use(column, value);
//   f.multiply(x.data(), 3, y.data());            // y = F x, rows in parallel
//   close_gaps(f.column, offset, written);         // rows built in parallel, then joined
//
// Memory: 4 bytes per column index plus sizeof(V) per value, plus 8 bytes per row.
// multiply: one pass over the entries, width multiply-adds each.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <type_traits>
#include <vector>

namespace polyrad {

namespace sparse_detail {
inline double scale(float v, std::int64_t) { return v; }
inline double scale(const std::array<float, 3>& v, std::int64_t j) { return v[j % 3]; }
}  // namespace sparse_detail

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
  // Empties the matrix and keeps its storage, so that refilling it maps no new pages.
  void clear() {
    rows = 0;
    start.assign(1, 0);
    column.clear();
    value.clear();
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
      if (column[mid] < c)
        lo = mid + 1;
      else
        hi = mid;
    }
    return (lo < start[r + 1] && column[lo] == c) ? value[lo] : V{};
  }

  // The entries of row r, for range-for: each a (column, value) pair.
  struct Entry {
    std::int32_t column;
    const V& value;
  };
  class RowIterator {
   public:
    RowIterator(const Csr* m, std::int64_t k) : m_(m), k_(k) {}
    Entry operator*() const { return {m_->column[k_], m_->value[k_]}; }
    RowIterator& operator++() {
      ++k_;
      return *this;
    }
    bool operator!=(const RowIterator& o) const { return k_ != o.k_; }

   private:
    const Csr* m_;
    std::int64_t k_;
  };
  struct Row {
    RowIterator b, e;
    RowIterator begin() const { return b; }
    RowIterator end() const { return e; }
  };
  Row row(std::int64_t r) const { return {{this, start[r]}, {this, start[r + 1]}}; }

  // acc[j] += sum over the entries of row r of value(j) x[width column + j], j < width: the row
  // loop of every product, entries summed in stored order (so every product gives the same bits).
  // x may be float (a kept block of the series, solve/series_precompute.cpp) or double.
  // An RGB value over a width that is a multiple of 3 runs by triples, without the j % 3 of
  // each term (the same products and sums, so the same bits; with it, the view rows' sums of the
  // room's default precompute, 135 columns a pixel, fell from 20 to 10 percent of its samples).
  template <typename X>
  void accumulate_row(std::int64_t r, const X* x, std::int64_t width, double* acc) const {
    if constexpr (std::is_same_v<V, std::array<float, 3>>) {
      if (width % 3 == 0) {
        for (std::int64_t k = start[r]; k < start[r + 1]; ++k) {
          const X* xr = x + width * static_cast<std::int64_t>(column[k]);
          const double v0 = value[k][0], v1 = value[k][1], v2 = value[k][2];
          for (std::int64_t j = 0; j < width; j += 3) {
            acc[j] += v0 * xr[j];
            acc[j + 1] += v1 * xr[j + 1];
            acc[j + 2] += v2 * xr[j + 2];
          }
        }
        return;
      }
    }
    for (std::int64_t k = start[r]; k < start[r + 1]; ++k) {
      const X* xr = x + width * static_cast<std::int64_t>(column[k]);
      for (std::int64_t j = 0; j < width; ++j) acc[j] += sparse_detail::scale(value[k], j) * xr[j];
    }
  }
  // y = A x with `width` values per row of x and y; y has rows x width entries, overwritten.
  void multiply(const double* x, std::int64_t width, double* y) const {
#pragma omp parallel for schedule(dynamic, 64)
    for (std::int64_t r = 0; r < rows; ++r) {
      double* yr = y + width * r;
      std::fill(yr, yr + width, 0.0);
      accumulate_row(r, x, width, yr);
    }
  }
};

// Rows built in parallel, each from its own offset in v (offset[r], r < written.size()) within
// a bound known beforehand, written[r] entries long: moves each down over the gaps before it,
// in row order, and sizes v to their total (its capacity freed when more than an eighth went
// unused). So the rows are held once, with no copy of each row of its own.
template <typename T>
void close_gaps(std::vector<T>& v, const std::vector<std::int64_t>& offset,
                const std::vector<std::int64_t>& written) {
  std::int64_t end = 0;
  for (std::size_t r = 0; r < written.size(); ++r) {
    if (end < offset[r])  // a forward copy: the target starts before the source
      std::copy_n(v.begin() + offset[r], written[r], v.begin() + end);
    end += written[r];
  }
  const std::size_t bound = v.size();
  v.resize(static_cast<std::size_t>(end));
  if (8 * v.size() < 7 * bound) v.shrink_to_fit();
}

}  // namespace polyrad
