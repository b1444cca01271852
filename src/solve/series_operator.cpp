// The stored operator and its product (solve/series_operator.h).
#include "polyrad/solve/series_operator.h"

#include <algorithm>

#include "polyrad/util/half.h"

namespace polyrad {

namespace {

// Every half value's float, so that the product converts by one table load (256 KiB, cached).
const float* half_table() {
  static const std::vector<float> table = [] {
    std::vector<float> t(65536);
    for (std::uint32_t h = 0; h < 65536; ++h) t[h] = half_to_float(static_cast<std::uint16_t>(h));
    return t;
  }();
  return table.data();
}

}  // namespace

void SeriesOperator::set_data(std::int64_t rows, std::vector<std::int64_t> start,
                              std::vector<std::uint32_t> column, std::vector<float> values_f,
                              std::vector<std::uint16_t> values_h) {
  rows_ = rows;
  own_start_ = std::move(start);
  own_column_ = std::move(column);
  own_f_ = std::move(values_f);
  own_h_ = std::move(values_h);
  start_ = own_start_.empty() ? nullptr : own_start_.data();
  column_ = own_column_.empty() ? nullptr : own_column_.data();
  values_ = precision == ValuePrecision::kFloat ? static_cast<const void*>(own_f_.data())
                                                : static_cast<const void*>(own_h_.data());
  keep_.reset();
}

void SeriesOperator::set_view(std::int64_t rows, const std::int64_t* start,
                              const std::uint32_t* column, const void* values,
                              std::shared_ptr<const void> keep) {
  rows_ = rows;
  start_ = start;
  column_ = column;
  values_ = values;
  keep_ = std::move(keep);
  own_start_.clear();
  own_column_.clear();
  own_f_.clear();
  own_h_.clear();
}

std::size_t SeriesOperator::bytes() const {
  std::size_t value_size =
      precision == ValuePrecision::kFloat ? sizeof(float) : sizeof(std::uint16_t);
  if (dense()) return static_cast<std::size_t>(nnz()) * 3 * value_size;
  return static_cast<std::size_t>(rows_ + 1) * sizeof(std::int64_t) +
         static_cast<std::size_t>(nnz()) * (sizeof(std::uint32_t) + 3 * value_size);
}

void SeriesOperator::densify_if(double fill) {
  if (dense() || rows_ == 0 ||
      static_cast<double>(nnz()) < fill * static_cast<double>(rows_ * cols()))
    return;
  const std::int64_t c = cols();
  std::vector<float> f;
  std::vector<std::uint16_t> h;
  if (precision == ValuePrecision::kFloat)
    f.assign(3 * rows_ * c, 0.0f);
  else
    h.assign(3 * rows_ * c, 0);
  for (std::int64_t r = 0; r < rows_; ++r)
    for (auto k = start_[r]; k < start_[r + 1]; ++k)
      for (int ch = 0; ch < 3; ++ch) {
        std::size_t to = 3 * (static_cast<std::size_t>(r) * c + column_[k]) + ch;
        if (precision == ValuePrecision::kFloat)
          f[to] = static_cast<const float*>(values_)[3 * k + ch];
        else
          h[to] = static_cast<const std::uint16_t*>(values_)[3 * k + ch];
      }
  set_data(rows_, {}, {}, std::move(f), std::move(h));
}

namespace {

// Products smaller than this run on one thread: waking the others costs more than they save.
constexpr std::size_t kParallelBytes = std::size_t(1) << 20;

// One dense row: out = sum over columns c of x[c] (RGB) * e[c] (RGB). Twelve independent float
// accumulators (four columns at a time) keep the adds from waiting on each other: with one per
// channel the loop was bound by addition latency at a third of the memory's bandwidth. Float
// sums suffice here, unlike the series' running sum: a row adds at most C products, rounding by
// about (C / 4) 2^-24 relative, below the stored values' own rounding for any practical C.
template <typename Load>
inline void dense_row(const Load& load, std::int64_t base, std::int64_t cols, const float* e,
                      float* out) {
  float acc[12] = {0.0f};
  std::int64_t c = 0;
  for (; c + 4 <= cols; c += 4) {
    float x[12];
    for (int j = 0; j < 12; ++j) x[j] = load(base + 3 * c + j);
#pragma omp simd
    for (int j = 0; j < 12; ++j) acc[j] += x[j] * e[3 * c + j];
  }
  float a0 = acc[0] + acc[3] + acc[6] + acc[9];
  float a1 = acc[1] + acc[4] + acc[7] + acc[10];
  float a2 = acc[2] + acc[5] + acc[8] + acc[11];
  for (; c < cols; ++c) {
    a0 += load(base + 3 * c) * e[3 * c];
    a1 += load(base + 3 * c + 1) * e[3 * c + 1];
    a2 += load(base + 3 * c + 2) * e[3 * c + 2];
  }
  out[0] = a0;
  out[1] = a1;
  out[2] = a2;
}

// One compressed row: entries [k0, k1) with their column indices; two entries at a time into
// separate accumulators.
template <typename Load>
inline void sparse_row(const Load& load, const std::uint32_t* column, std::int64_t k0,
                       std::int64_t k1, const float* e, float* out) {
  float a[6] = {0.0f};
  std::int64_t k = k0;
  for (; k + 2 <= k1; k += 2) {
    const float* x = e + 3 * static_cast<std::size_t>(column[k]);
    const float* y = e + 3 * static_cast<std::size_t>(column[k + 1]);
    a[0] += load(3 * k) * x[0];
    a[1] += load(3 * k + 1) * x[1];
    a[2] += load(3 * k + 2) * x[2];
    a[3] += load(3 * k + 3) * y[0];
    a[4] += load(3 * k + 4) * y[1];
    a[5] += load(3 * k + 5) * y[2];
  }
  if (k < k1) {
    const float* x = e + 3 * static_cast<std::size_t>(column[k]);
    a[0] += load(3 * k) * x[0];
    a[1] += load(3 * k + 1) * x[1];
    a[2] += load(3 * k + 2) * x[2];
  }
  out[0] = a[0] + a[3];
  out[1] = a[1] + a[4];
  out[2] = a[2] + a[5];
}

// How far ahead of the row being summed the dense product asks for its values, once they come
// from memory rather than cache. One thread reading one stream keeps too few cache misses in
// flight to use the memory's bandwidth (0.55 to 0.6 of a STREAM triad here, which reads two
// streams and writes a third); requesting the row about 8 KiB ahead raised that to 0.77 to 0.95
// on one thread, 0.59 to 0.92 on two (docs/benchmarks.md). From cache the prefetches only cost
// instructions (0.7 fell to 0.44 at 2 to 8 MiB), hence the threshold.
constexpr std::int64_t kPrefetchBytes = 8192;
constexpr std::size_t kPrefetchAbove = std::size_t(16) << 20;

// The dense float rows read straight from the array, which the compiler vectorises fully.
template <bool Prefetch>
void dense_float_rows(const float* __restrict v, std::int64_t rows, std::int64_t cols,
                      const float* __restrict e, float* __restrict out, bool parallel) {
  const std::int64_t row_bytes = 3 * cols * static_cast<std::int64_t>(sizeof(float));
  const std::int64_t ahead =
      std::max<std::int64_t>(1, kPrefetchBytes / std::max<std::int64_t>(row_bytes, 1));
#pragma omp parallel for schedule(static) if (parallel)
  for (std::int64_t r = 0; r < rows; ++r) {
    const float* x = v + 3 * r * cols;
    if (Prefetch && r + ahead < rows) {
      const char* next = reinterpret_cast<const char*>(x + 3 * ahead * cols);
      for (std::int64_t b = 0; b < row_bytes; b += 64) __builtin_prefetch(next + b);
    }
    float acc[12] = {0.0f};
    std::int64_t c = 0;
    for (; c + 4 <= cols; c += 4) {
#pragma omp simd
      for (int j = 0; j < 12; ++j) acc[j] += x[3 * c + j] * e[3 * c + j];
    }
    float a0 = acc[0] + acc[3] + acc[6] + acc[9];
    float a1 = acc[1] + acc[4] + acc[7] + acc[10];
    float a2 = acc[2] + acc[5] + acc[8] + acc[11];
    for (; c < cols; ++c) {
      a0 += x[3 * c] * e[3 * c];
      a1 += x[3 * c + 1] * e[3 * c + 1];
      a2 += x[3 * c + 2] * e[3 * c + 2];
    }
    out[3 * r] = a0;
    out[3 * r + 1] = a1;
    out[3 * r + 2] = a2;
  }
}

template <typename Load>
void product(const SeriesOperator& q, const Load& load, const float* e, float* out) {
  const std::int64_t rows = q.rows(), cols = q.cols();
  const bool parallel = q.bytes() >= kParallelBytes;
  if (q.dense() && q.precision == ValuePrecision::kFloat) {
    const auto* v = static_cast<const float*>(q.values());
    if (q.bytes() >= kPrefetchAbove)
      dense_float_rows<true>(v, rows, cols, e, out, parallel);
    else
      dense_float_rows<false>(v, rows, cols, e, out, parallel);
    return;
  }
  if (q.dense()) {  // the values stream in order, no index is read
#pragma omp parallel for schedule(static) if (parallel)
    for (std::int64_t r = 0; r < rows; ++r) dense_row(load, 3 * r * cols, cols, e, out + 3 * r);
    return;
  }
  const std::int64_t* start = q.start();
  const std::uint32_t* column = q.column();
#pragma omp parallel for schedule(static) if (parallel)
  for (std::int64_t r = 0; r < rows; ++r)
    sparse_row(load, column, start[r], start[r + 1], e, out + 3 * r);
}

}  // namespace

void SeriesOperator::apply(const float* e, float* out) const {
  if (precision == ValuePrecision::kFloat) {
    const float* v = static_cast<const float*>(values_);
    product(
        *this, [v](std::int64_t i) { return v[i]; }, e, out);
  } else {
    const std::uint16_t* v = static_cast<const std::uint16_t*>(values_);
    const float* table = half_table();
    product(
        *this, [v, table](std::int64_t i) { return table[v[i]]; }, e, out);
  }
}

std::vector<std::string> SeriesOperator::light_names() const {
  std::vector<std::string> names;
  for (const auto& c : columns)
    if (names.empty() || names.back() != c.object) names.push_back(c.object);
  return names;
}

std::vector<float> SeriesOperator::column_emission(const std::map<std::string, Rgb>& lights) const {
  std::vector<std::string> names = light_names();
  for (const auto& [name, value] : lights)
    if (std::find(names.begin(), names.end(), name) == names.end()) {
      std::string known;
      for (const auto& n : names) known += (known.empty() ? "" : ", ") + n;
      throw InputError("'" + name + "' is not a light of this operator (lights: " + known + ")");
    }
  std::vector<float> e(3 * columns.size());
  for (size_t c = 0; c < columns.size(); ++c) {
    auto it = lights.find(columns[c].object);
    Rgb v = it != lights.end() ? it->second : columns[c].emission;
    for (int ch = 0; ch < 3; ++ch) e[3 * c + ch] = static_cast<float>(v[ch]);
  }
  return e;
}

std::vector<Rgb> patch_emission(const SeriesMetadata& q, const std::vector<float>& e,
                                const PatchSet& patches, const Scene& scene) {
  POLYRAD_CHECK(e.size() == 3 * q.columns.size());
  std::vector<Rgb> out(patches.size(), Rgb::Zero());
  for (size_t c = 0; c < q.columns.size(); ++c) {
    const Rgb v(e[3 * c], e[3 * c + 1], e[3 * c + 2]);
    const SeriesColumn& col = q.columns[c];
    if (col.patch >= 0) {
      POLYRAD_CHECK(static_cast<size_t>(col.patch) < patches.size());
      out[col.patch] = v;
      continue;
    }
    const ObjectId obj = scene.find_object(col.object);
    for (size_t p = 0; p < patches.size(); ++p)
      if (patches[p].object == obj) out[p] = v;
  }
  return out;
}

Image series_image(const SeriesOperator& q, const std::vector<float>& out) {
  POLYRAD_CHECK(q.output == SeriesOutput::kView);
  Image img(q.width, q.height);
  img.rgb.assign(out.begin(), out.begin() + 3 * q.rows());
  return img;
}

Field series_field(const SeriesOperator& q, const std::vector<float>& out) {
  POLYRAD_CHECK(q.output == SeriesOutput::kSolution);
  Field u(q.rows(), 3);
  for (std::int64_t r = 0; r < q.rows(); ++r)
    for (int c = 0; c < 3; ++c) u(r, c) = out[3 * r + c];
  return u;
}

}  // namespace polyrad
