// The truncated power series and its product (series.h); papers/glossy-radiosity.md, sec. 5-6.
#include "polyrad/solve/series.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "polyrad/util/half.h"
#include "polyrad/util/progress.h"
#include "polyrad/transport/reorder.h"
#include "polyrad/solve/solver.h"

namespace polyrad {

const char* series_output_name(SeriesOutput o) { return o == SeriesOutput::kView ? "view" : "solution"; }
const char* value_precision_name(ValuePrecision p) { return p == ValuePrecision::kFloat ? "float" : "half"; }
const char* series_basis_name(SeriesBasis b) { return b == SeriesBasis::kPatch ? "patch" : "object"; }
const char* series_reorder_name(SeriesReorder r) { return r == SeriesReorder::kNone ? "none" : "rcm"; }

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

// Growth of the term norms for this many terms in a row means the series diverges.
constexpr int kGrowthTerms = 8;

struct Terms {
  int order = 0;
  std::vector<double> norms;  // relative to ||S||
  double spectral_radius = 0.0;
  double aposteriori = 0.0;
  double residual_bound = INFINITY;
};


// q, the decay of the term norms (solver.h, extrapolated_decay), capped by a_max, which bounds
// the spectral radius (section 5).
double ratio_estimate(const std::vector<double>& norms, double a_max) {
  double q = extrapolated_decay(norms);
  return a_max > 0.0 ? std::min(q, a_max) : q;
}

// Term norms ||T^n S|| of all columns together (S = 1 on every emitting patch; every column is
// non-negative, so the norm of the sum is the sum of the norms) and the order K: given, or the
// smallest K whose a-priori bound or a-posteriori estimate meets the tolerance. Channels decay
// at their own rates (coloured reflectances), so the estimate is the worst channel's: then any
// emission colour meets the tolerance.
Terms choose_order(const TransportOperator& t, const Field& s, const SeriesOptions& o) {
  const double a = t.max_albedo();
  auto channel_norms = [&](const Field& f) { return t.flux_norm_channels(f); };
  const Eigen::Array3d s_norm = channel_norms(s);
  Terms terms;
  terms.norms.push_back(1.0);
  if (s_norm.sum() == 0.0) return terms;
  std::vector<double> channel[3] = {{1.0}, {1.0}, {1.0}};
  Eigen::Array3d acc = Eigen::Array3d::Ones();
  Field term = s, next;
  const int limit = o.order >= 0 ? o.order : o.max_order;
  for (int n = 1; n <= limit; ++n) {
    t.apply(term, next);
    term.swap(next);
    Eigen::Array3d norm = channel_norms(term) / s_norm.max(1e-300);
    double total = channel_norms(term).sum() / s_norm.sum();
    if (!norm.isFinite().all())
      throw NumericalError("the power series produced non-finite terms at n = " + std::to_string(n));
    terms.norms.push_back(total);
    acc += norm;  // non-negative terms: the norm of the sum is the sum of the norms
    int m = static_cast<int>(terms.norms.size());
    if (m > kGrowthTerms + 1) {
      bool growing = true;
      for (int k = m - kGrowthTerms; k < m; ++k) growing = growing && terms.norms[k] > terms.norms[k - 1];
      if (growing && total > 1.0) {
        std::ostringstream msg;
        msg << "the power series diverges: its terms grew by " << total / terms.norms[m - 2]
            << " per order over the last " << kGrowthTerms << " (spectral radius above 1)";
        if (a > 1.0) msg << "; " << t.divergence_hint();
        throw NumericalError(msg.str());
      }
    }
    terms.spectral_radius = 0.0;
    terms.aposteriori = 0.0;
    for (int c = 0; c < 3; ++c) {
      if (s_norm[c] == 0.0) continue;
      channel[c].push_back(norm[c]);
      double q = ratio_estimate(channel[c], a);
      terms.spectral_radius = std::max(terms.spectral_radius, q);
      terms.aposteriori = std::max(terms.aposteriori, q < 1.0 ? norm[c] * q / (1.0 - q) / acc[c] : INFINITY);
    }
    terms.order = n;
    if (o.order >= 0) continue;
    double apriori = a < 1.0 ? std::pow(a, n + 1) / (1.0 - a) : INFINITY;
    if (apriori <= o.tolerance || (n >= 3 && terms.aposteriori <= o.tolerance)) return terms;
  }
  if (o.order < 0)
    throw NumericalError("the power series did not reach the tolerance " +
                         std::to_string(o.tolerance) + " within " + std::to_string(o.max_order) +
                         " terms");
  return terms;
}

// Chebyshev: rho from a few power steps unless given, then the order from the residual, a
// rigorous bound in the flux norm: ||x - x_K|| <= ||e + T x_K - x_K|| / (1 - a_max).
Terms choose_chebyshev_order(const TransportOperator& t, const Field& s, const SeriesOptions& o,
                             double* rho) {
  const double a = t.max_albedo();
  if (!(a < 1.0)) throw NumericalError("Chebyshev acceleration needs every albedo below 1; " + t.divergence_hint());
  if (*rho <= 0.0) *rho = estimate_spectral_radius(t, s);
  const Eigen::Array3d s_norm = t.flux_norm_channels(s);
  Terms terms;
  terms.spectral_radius = *rho;
  terms.norms.push_back(1.0);
  ChebyshevIteration<Field> cheb(t, s, *rho);
  const int limit = o.order >= 0 ? o.order + 1 : o.max_order;
  for (int n = 0; n < limit; ++n) {
    Eigen::Array3d x_norm = t.flux_norm_channels(cheb.x());
    const Field& residual = cheb.step();  // residual of x_n
    Eigen::Array3d r_norm = t.flux_norm_channels(residual);
    double bound = 0.0;
    for (int c = 0; c < 3; ++c)
      if (s_norm[c] > 0.0) bound = std::max(bound, r_norm[c] / (1.0 - a) / x_norm[c]);
    if (!std::isfinite(bound)) throw NumericalError("the Chebyshev polynomial produced non-finite terms");
    if (n > 0) terms.norms.push_back(r_norm.sum() / s_norm.sum());
    terms.order = n;
    terms.residual_bound = bound;
    if (o.order < 0 && bound <= o.tolerance) return terms;
    if (n > 2 * kGrowthTerms && terms.norms.back() > terms.norms.front())
      throw NumericalError("the Chebyshev polynomial diverges: its residual grows (the spectral radius " +
                           std::to_string(*rho) + " it assumed is too small, or the spectrum is not real)");
  }
  if (o.order < 0)
    throw NumericalError("the Chebyshev polynomial did not reach the tolerance within " +
                         std::to_string(o.max_order) + " terms");
  return terms;
}

// P_K S for one block of columns by the running sum u_K = sum_{n<=K} T^n S (eq. 10), or the
// Chebyshev polynomial's x_K: `order` products with op, which is T or its renumbered copy.
template <typename Op>
FieldBlock block_polynomial(const Op& op, FieldBlock term, int order, bool chebyshev, double rho,
                            Progress& progress) {
  if (chebyshev) {
    ChebyshevIteration<FieldBlock, Op> cheb(op, term, rho);
    for (int n = 1; n <= order; ++n) {
      cheb.step();
      progress.advance();
    }
    return cheb.x();
  }
  FieldBlock acc = term, next;
  for (int n = 1; n <= order; ++n) {
    op.apply(term, next);
    term.swap(next);
    acc += term;
    progress.advance();
  }
  return acc;
}

// The numbering of the block products (SeriesOptions::reorder): null for T's own, else T's
// renumbered copy. Records the ordering's cost and T's bandwidth before and after.
std::unique_ptr<PermutedTransport> reordered_transport(const TransportOperator& t,
                                                       SeriesReorder reorder, SeriesReport& rep) {
  auto t0 = std::chrono::steady_clock::now();
  std::unique_ptr<PermutedTransport> permuted;
  if (reorder == SeriesReorder::kRcm)
    permuted = std::make_unique<PermutedTransport>(t, reverse_cuthill_mckee(t.weights()));
  rep.reorder = reorder;
  rep.reorder_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  rep.bandwidth_before = bandwidth(t.weights());
  rep.bandwidth_after = permuted ? bandwidth(permuted->weights()) : rep.bandwidth_before;
  return permuted;
}

}  // namespace

std::vector<SeriesColumn> series_columns(const PatchSet& patches, const Scene& scene,
                                         SeriesBasis basis) {
  std::vector<SeriesColumn> columns;
  if (basis == SeriesBasis::kObject) {
    for (const auto& o : scene.objects)
      if (o.is_emitter) columns.push_back({o.name, -1, o.emission});
    return columns;
  }
  for (PatchId p = 0; p < static_cast<PatchId>(patches.size()); ++p)
    if (patches[p].emitter)
      columns.push_back({scene.objects[patches[p].object].name, p, patches[p].emission});
  return columns;
}

SeriesOperator precompute_series(const TransportOperator& t, const PatchSet& patches,
                                 const Scene& scene, const Gather* gather,
                                 const SeriesOptions& o) {
  auto t0 = std::chrono::steady_clock::now();
  const bool view = o.output == SeriesOutput::kView;
  if (view && !gather) throw InputError("a view-mode series needs the camera gather");
  SeriesOperator q;
  q.output = o.output;
  q.basis = o.basis;
  q.precision = o.precision;
  q.columns = series_columns(patches, scene, o.basis);
  q.layout = t.layout();
  q.scene_file = scene.file;
  q.scene_hash = scene.hash;
  if (view) {
    q.width = gather->width;
    q.height = gather->height;
  }
  const auto cols = static_cast<std::int64_t>(q.columns.size());
  if (cols == 0) throw InputError("the scene has no emitting object: nothing to precompute");
  std::unique_ptr<PermutedTransport> permuted = reordered_transport(t, o.reorder, q.report);
  auto unknown = [&](PatchId p) { return permuted ? permuted->permutation().position[p] : p; };

  // Which patches each column lights.
  std::vector<std::vector<PatchId>> lit(cols);
  for (std::int64_t c = 0; c < cols; ++c) {
    if (q.columns[c].patch >= 0) {
      lit[c].push_back(q.columns[c].patch);
      continue;
    }
    ObjectId obj = scene.find_object(q.columns[c].object);
    for (PatchId p = 0; p < static_cast<PatchId>(patches.size()); ++p)
      if (patches[p].object == obj) lit[c].push_back(p);
  }
  Field s = Field::Zero(t.size(), 3);
  for (const auto& list : lit)
    for (PatchId p : list) s.row(p).setOnes();
  const bool chebyshev = o.acceleration == SeriesAcceleration::kChebyshev;
  double rho = o.chebyshev_radius;
  Terms terms = chebyshev ? choose_chebyshev_order(t, s, o, &rho) : choose_order(t, s, o);
  const int order = terms.order;

  const std::int64_t rows = view ? static_cast<std::int64_t>(gather->width) * gather->height : t.size();
  std::vector<std::vector<std::int64_t>> batch_start;
  std::vector<std::vector<std::uint32_t>> batch_column;
  std::vector<std::vector<float>> batch_value;
  double dropped = 0.0, total = 0.0;
  const int batch = std::max(1, o.column_batch);
  Progress progress("series precompute", (cols + batch - 1) / batch * (order + 1), o.progress);

  for (std::int64_t c0 = 0; c0 < cols; c0 += batch) {
    const int width = static_cast<int>(std::min<std::int64_t>(batch, cols - c0));
    FieldBlock term = FieldBlock::Zero(t.size(), 3 * width);
    for (int c = 0; c < width; ++c)
      for (PatchId p : lit[c0 + c]) term.block(unknown(p), 3 * c, 1, 3).setOnes();
    progress.advance();
    // In the products' numbering; back in T's before the gather and the rows.
    FieldBlock acc = permuted ? permuted->to_original(block_polynomial(*permuted, std::move(term), order,
                                                                       chebyshev, rho, progress))
                              : block_polynomial(t, std::move(term), order, chebyshev, rho, progress);
    // The rows: the unknowns themselves, or the pixels through the gather.
    FieldBlock out;
    if (view) {
      out = FieldBlock::Zero(rows, 3 * width);
      const auto& g = gather->g;
#pragma omp parallel for schedule(static)
      for (std::int64_t r = 0; r < rows; ++r)
        for (auto k = g.start[r]; k < g.start[r + 1]; ++k) {
          const double* x = acc.data() + acc.cols() * static_cast<Eigen::Index>(g.column[k]);
          double* y = out.data() + out.cols() * r;
          for (int c = 0; c < 3 * width; ++c) y[c] += g.value[k][c % 3] * x[c];
        }
    } else {
      out.swap(acc);
    }
    // Drop the smallest entries of each column while their share of the column's energy (the
    // flux-weighted sum over channels) stays within `drop`: the image or solution loses at most
    // that fraction of each light's contribution, whatever the light's colour. (A threshold
    // relative to the column's largest entry would not: in view mode that entry is a pixel
    // seeing the lamp, and most of the indirect light falls below it.) Measure what the dropped
    // entries would have added for the scene's emission.
    auto energy = [&](std::int64_t r, int c) {
      const double w = view ? 1.0 : t.flux_weight()[r];
      return w * (out(r, 3 * c) + out(r, 3 * c + 1) + out(r, 3 * c + 2));
    };
    std::vector<double> threshold(width, 0.0);
    if (o.drop > 0.0) {
      std::vector<double> e(rows);
      for (int c = 0; c < width; ++c) {
        double column_total = 0.0;
        for (std::int64_t r = 0; r < rows; ++r) column_total += (e[r] = energy(r, c));
        std::sort(e.begin(), e.end());
        double cumulative = 0.0;
        for (std::int64_t r = 0; r < rows; ++r) {
          if (cumulative + e[r] > o.drop * column_total) {
            threshold[c] = e[r];  // entries below this one are dropped
            break;
          }
          cumulative += e[r];
        }
      }
    }
    std::vector<std::int64_t> bs{0};
    std::vector<std::uint32_t> bc;
    std::vector<float> bv;
    for (std::int64_t r = 0; r < rows; ++r) {
      const double w = view ? 1.0 : t.flux_weight()[r];
      for (int c = 0; c < width; ++c) {
        const SeriesColumn& col = q.columns[c0 + c];
        double v[3] = {out(r, 3 * c), out(r, 3 * c + 1), out(r, 3 * c + 2)};
        double mass = w * (v[0] * col.emission[0] + v[1] * col.emission[1] + v[2] * col.emission[2]);
        total += mass;
        if (std::max({v[0], v[1], v[2]}) <= 0.0) continue;
        if (energy(r, c) < threshold[c]) {
          dropped += mass;
          continue;
        }
        bc.push_back(static_cast<std::uint32_t>(c0 + c));
        for (double x : v) bv.push_back(static_cast<float>(x));
      }
      bs.push_back(static_cast<std::int64_t>(bc.size()));
    }
    batch_start.push_back(std::move(bs));
    batch_column.push_back(std::move(bc));
    batch_value.push_back(std::move(bv));
  }
  progress.finish();

  // Rows of Q: each batch's part of the row, batches in column order.
  std::vector<std::int64_t> start(rows + 1, 0);
  for (std::int64_t r = 0; r < rows; ++r) {
    std::int64_t n = 0;
    for (const auto& bs : batch_start) n += bs[r + 1] - bs[r];
    start[r + 1] = start[r] + n;
  }
  std::vector<std::uint32_t> column(start[rows]);
  std::vector<float> values_f;
  std::vector<std::uint16_t> values_h;
  (o.precision == ValuePrecision::kFloat ? values_f.resize(3 * start[rows]) : values_h.resize(3 * start[rows]));
#pragma omp parallel for schedule(static)
  for (std::int64_t r = 0; r < rows; ++r) {
    std::int64_t at = start[r];
    for (size_t b = 0; b < batch_start.size(); ++b)
      for (auto k = batch_start[b][r]; k < batch_start[b][r + 1]; ++k, ++at) {
        column[at] = batch_column[b][k];
        for (int ch = 0; ch < 3; ++ch) {
          float v = batch_value[b][3 * k + ch];
          if (o.precision == ValuePrecision::kFloat) values_f[3 * at + ch] = v;
          else values_h[3 * at + ch] = float_to_half(v);
        }
      }
  }
  q.set_data(rows, std::move(start), std::move(column), std::move(values_f), std::move(values_h));
  q.densify_if(0.75);

  SeriesReport& rep = q.report;
  rep.order = order;
  rep.max_albedo = t.max_albedo();
  rep.apriori_bound = rep.max_albedo < 1.0 ? std::pow(rep.max_albedo, order + 1) / (1.0 - rep.max_albedo) : INFINITY;
  rep.aposteriori_estimate = terms.aposteriori;
  rep.spectral_radius = terms.spectral_radius;
  rep.term_norms = terms.norms;
  rep.acceleration = o.acceleration;
  rep.chebyshev_radius = chebyshev ? rho : 0.0;
  rep.residual_bound = terms.residual_bound;
  rep.dropped_energy = dropped;
  rep.dropped_relative = total > 0.0 ? dropped / total : 0.0;
  rep.nnz = q.nnz();
  rep.bytes = q.bytes();
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (view) q.gather = gather->options;
  return q;
}

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
  std::size_t value_size = precision == ValuePrecision::kFloat ? sizeof(float) : sizeof(std::uint16_t);
  if (dense()) return static_cast<std::size_t>(nnz()) * 3 * value_size;
  return static_cast<std::size_t>(rows_ + 1) * sizeof(std::int64_t) +
         static_cast<std::size_t>(nnz()) * (sizeof(std::uint32_t) + 3 * value_size);
}

void SeriesOperator::densify_if(double fill) {
  if (dense() || rows_ == 0 || static_cast<double>(nnz()) < fill * static_cast<double>(rows_ * cols()))
    return;
  const std::int64_t c = cols();
  std::vector<float> f;
  std::vector<std::uint16_t> h;
  if (precision == ValuePrecision::kFloat) f.assign(3 * rows_ * c, 0.0f);
  else h.assign(3 * rows_ * c, 0);
  for (std::int64_t r = 0; r < rows_; ++r)
    for (auto k = start_[r]; k < start_[r + 1]; ++k)
      for (int ch = 0; ch < 3; ++ch) {
        std::size_t to = 3 * (static_cast<std::size_t>(r) * c + column_[k]) + ch;
        if (precision == ValuePrecision::kFloat) f[to] = static_cast<const float*>(values_)[3 * k + ch];
        else h[to] = static_cast<const std::uint16_t*>(values_)[3 * k + ch];
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
inline void dense_row(const Load& load, std::int64_t base, std::int64_t cols, const float* e, float* out) {
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
inline void sparse_row(const Load& load, const std::uint32_t* column, std::int64_t k0, std::int64_t k1,
                       const float* e, float* out) {
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
  const std::int64_t ahead = std::max<std::int64_t>(1, kPrefetchBytes / std::max<std::int64_t>(row_bytes, 1));
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
  for (std::int64_t r = 0; r < rows; ++r) sparse_row(load, column, start[r], start[r + 1], e, out + 3 * r);
}

}  // namespace

void SeriesOperator::apply(const float* e, float* out) const {
  if (precision == ValuePrecision::kFloat) {
    const float* v = static_cast<const float*>(values_);
    product(*this, [v](std::int64_t i) { return v[i]; }, e, out);
  } else {
    const std::uint16_t* v = static_cast<const std::uint16_t*>(values_);
    const float* table = half_table();
    product(*this, [v, table](std::int64_t i) { return table[v[i]]; }, e, out);
  }
}

std::vector<std::string> SeriesOperator::light_names() const {
  std::vector<std::string> names;
  for (const auto& c : columns)
    if (names.empty() || names.back() != c.object) names.push_back(c.object);
  return names;
}

std::vector<float> SeriesOperator::column_emission(const std::map<std::string, Rgb>& overrides) const {
  std::vector<std::string> names = light_names();
  for (const auto& [name, value] : overrides)
    if (std::find(names.begin(), names.end(), name) == names.end()) {
      std::string known;
      for (const auto& n : names) known += (known.empty() ? "" : ", ") + n;
      throw InputError("'" + name + "' is not a light of this operator (lights: " + known + ")");
    }
  std::vector<float> e(3 * columns.size());
  for (size_t c = 0; c < columns.size(); ++c) {
    auto it = overrides.find(columns[c].object);
    Rgb v = it != overrides.end() ? it->second : columns[c].emission;
    for (int ch = 0; ch < 3; ++ch) e[3 * c + ch] = static_cast<float>(v[ch]);
  }
  return e;
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
