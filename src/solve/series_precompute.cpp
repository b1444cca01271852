// The series precompute (solve/series_precompute.h); papers/glossy-radiosity.md, sec. 5-6.
#include "polyrad/solve/series_precompute.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "polyrad/geometry/mesher.h"
#include "polyrad/solve/solver.h"
#include "polyrad/transport/hierarchy.h"
#include "polyrad/transport/permuted_transport.h"
#include "polyrad/transport/reorder.h"
#include "polyrad/util/half.h"
#include "polyrad/util/progress.h"
#include "polyrad/util/timer.h"

namespace polyrad {

namespace {

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
      throw NumericalError("the power series produced non-finite terms at n = " +
                           std::to_string(n));
    terms.norms.push_back(total);
    acc += norm;  // non-negative terms: the norm of the sum is the sum of the norms
    int m = static_cast<int>(terms.norms.size());
    if (m > kGrowthTerms + 1) {
      bool growing = true;
      for (int k = m - kGrowthTerms; k < m; ++k)
        growing = growing && terms.norms[k] > terms.norms[k - 1];
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
      terms.aposteriori =
          std::max(terms.aposteriori, q < 1.0 ? norm[c] * q / (1.0 - q) / acc[c] : INFINITY);
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
  if (!(a < 1.0))
    throw NumericalError("Chebyshev acceleration needs every albedo below 1; " +
                         t.divergence_hint());
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
    if (!std::isfinite(bound))
      throw NumericalError("the Chebyshev polynomial produced non-finite terms");
    if (n > 0) terms.norms.push_back(r_norm.sum() / s_norm.sum());
    terms.order = n;
    terms.residual_bound = bound;
    if (o.order < 0 && bound <= o.tolerance) return terms;
    if (n > 2 * kGrowthTerms && terms.norms.back() > terms.norms.front())
      throw NumericalError(
          "the Chebyshev polynomial diverges: its residual grows (the spectral radius " +
          std::to_string(*rho) + " it assumed is too small, or the spectrum is not real)");
  }
  if (o.order < 0)
    throw NumericalError("the Chebyshev polynomial did not reach the tolerance within " +
                         std::to_string(o.max_order) + " terms");
  return terms;
}

// The blocks a batch's products run on, kept from batch to batch: made afresh for each, their
// pages were touched anew (the room's default precompute took 1.7 million page faults, 0.76
// with them kept). With view rows the sum's float copy (half a block) is made beside all three.
struct BatchBlocks {
  FieldBlock term, next, acc;
};
// Bytes per unknown and column of a batch at its peak: three blocks of 3 doubles and a float copy.
constexpr double kBatchBytes = 3.5 * 3.0 * 8.0;

// P_K S for one block of columns, S in blocks.term, by the running sum
// u_K = sum_{n<=K} T^n S (eq. 10), or the Chebyshev polynomial's x_K: `order` products with op,
// which is T or its renumbered copy. The result is blocks.acc.
template <typename Op>
const FieldBlock& block_polynomial(const Op& op, BatchBlocks& blocks, int order, bool chebyshev,
                                   double rho, Progress& progress) {
  FieldBlock &term = blocks.term, &next = blocks.next, &acc = blocks.acc;
  if (chebyshev) {
    ChebyshevIteration<FieldBlock, Op> cheb(op, term, rho);
    for (int n = 1; n <= order; ++n) {
      cheb.step();
      progress.advance();
    }
    acc = cheb.x();
    return acc;
  }
  acc = term;
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
  const Stopwatch watch;
  std::unique_ptr<PermutedTransport> permuted;
  if (reorder == SeriesReorder::kRcm)
    permuted = std::make_unique<PermutedTransport>(t, reverse_cuthill_mckee(t.weights()));
  rep.reorder = reorder;
  rep.reorder_seconds = watch.seconds();
  rep.bandwidth_before = bandwidth(t.weights());
  rep.bandwidth_after = permuted ? bandwidth(permuted->weights()) : rep.bandwidth_before;
  return permuted;
}

// The column that lights each world patch (-1: none): its own (patch basis) or its object's.
std::vector<int> patch_columns(const std::vector<SeriesColumn>& columns, const World& world) {
  const PatchSet& patches = world.patches();
  std::vector<int> column_of(patches.size(), -1);
  for (size_t c = 0; c < columns.size(); ++c) {
    if (columns[c].patch >= 0) {
      column_of[columns[c].patch] = static_cast<int>(c);
      continue;
    }
    const ObjectId obj = world.scene().find_object(columns[c].object);
    for (PatchId p = 0; p < static_cast<PatchId>(patches.size()); ++p)
      if (patches[p].object == obj) column_of[p] = static_cast<int>(c);
  }
  return column_of;
}

// The world patch of each B unknown: itself, or the root its leaf lies under (a hierarchy's).
std::vector<PatchId> unknown_roots(const TransportOperator& t, const World& world) {
  const ElementHierarchy* h = t.layout().hierarchy.get();
  std::vector<PatchId> root(t.num_patches());
  for (PatchId u = 0; u < static_cast<PatchId>(root.size()); ++u)
    root[u] = h ? h->elements()[h->element_of_leaf(u)].root : u;
  (void)world;
  return root;
}

// Which B unknowns each column lights: those of its patch, or of every patch of its object.
std::vector<std::vector<PatchId>> lit_unknowns(const std::vector<SeriesColumn>& columns,
                                               const std::vector<PatchId>& root,
                                               const World& world) {
  std::vector<int> column_of = patch_columns(columns, world);
  std::vector<std::vector<PatchId>> lit(columns.size());
  for (PatchId u = 0; u < static_cast<PatchId>(root.size()); ++u)
    if (const int c = column_of[root[u]]; c >= 0) lit[c].push_back(u);
  return lit;
}

// The flux-weighted energy of row r of column c in a block of rows (3 values a column), by
// magnitude: a view row of a gather that reads the indirect light from the mesh may be negative
// in one column (an emitting object's -D e is put on its first patch's: render/mesh_direct.h).
double row_energy(const FieldBlock& out, std::int64_t r, int c, double weight) {
  return weight *
         (std::abs(out(r, 3 * c)) + std::abs(out(r, 3 * c + 1)) + std::abs(out(r, 3 * c + 2)));
}

// Drop the smallest entries of each column while their share of the column's energy (the
// flux-weighted sum over channels) stays within `drop`: the image or solution loses at most
// that fraction of each light's contribution, whatever the light's colour. (A threshold
// relative to the column's largest entry would not: in view mode that entry is a pixel seeing
// the lamp, and most of the indirect light falls below it.) Returns each column's threshold:
// entries of lower energy are dropped. Energies are magnitudes: where a column has negative
// entries (the indirect light from the mesh puts an object's -D e on one patch's column) the
// bound holds for the sum of the magnitudes, not for the column's net light.

std::vector<double> drop_thresholds(const FieldBlock& out, int width, double drop,
                                    const std::vector<double>* flux_weight) {
  std::vector<double> threshold(width, 0.0);
  if (!(drop > 0.0)) return threshold;
  const std::int64_t rows = out.rows();
  std::vector<double> e(rows);
  for (int c = 0; c < width; ++c) {
    double column_total = 0.0;
    for (std::int64_t r = 0; r < rows; ++r)
      column_total += (e[r] = row_energy(out, r, c, flux_weight ? (*flux_weight)[r] : 1.0));
    std::sort(e.begin(), e.end());
    double cumulative = 0.0;
    for (std::int64_t r = 0; r < rows; ++r) {
      if (cumulative + e[r] > drop * column_total) {
        threshold[c] = e[r];
        break;
      }
      cumulative += e[r];
    }
  }
  return threshold;
}

// Q's rows gathered batch by batch of columns: each batch a compressed-rows piece; assemble()
// joins them row by row, batches in column order, in the precision asked for.
class RowPieces {
 public:
  explicit RowPieces(std::int64_t rows) : rows_(rows) {}
  // Appends the rows of one batch (columns c0 .. c0 + width of Q), dropping entries under the
  // thresholds. Measures, for the columns' scene emission, what dropping removed.
  void add(const FieldBlock& out, std::int64_t c0, int width,
           const std::vector<SeriesColumn>& columns, const std::vector<double>& threshold,
           const std::vector<double>* flux_weight) {
    std::vector<std::int64_t> bs{0};
    std::vector<std::uint32_t> bc;
    std::vector<float> bv;
    for (std::int64_t r = 0; r < rows_; ++r) {
      const double w = flux_weight ? (*flux_weight)[r] : 1.0;
      for (int c = 0; c < width; ++c) {
        const SeriesColumn& col = columns[c0 + c];
        const double v[3] = {out(r, 3 * c), out(r, 3 * c + 1), out(r, 3 * c + 2)};
        // By magnitude, as the drop judges entries: a negative one dropped adds light.
        const double mass =
            w * std::abs(v[0] * col.emission[0] + v[1] * col.emission[1] + v[2] * col.emission[2]);
        total_ += mass;
        if (v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0) continue;
        if (row_energy(out, r, c, w) < threshold[c]) {
          dropped_ += mass;
          continue;
        }
        bc.push_back(static_cast<std::uint32_t>(c0 + c));
        for (double x : v) bv.push_back(static_cast<float>(x));
      }
      bs.push_back(static_cast<std::int64_t>(bc.size()));
    }
    start_.push_back(std::move(bs));
    column_.push_back(std::move(bc));
    value_.push_back(std::move(bv));
  }

  // The rows into q (compressed, then dense when at least 3/4 of the entries are stored).
  void assemble(SeriesOperator& q) const {
    std::vector<std::int64_t> start(rows_ + 1, 0);
    for (std::int64_t r = 0; r < rows_; ++r) {
      std::int64_t n = 0;
      for (const auto& bs : start_) n += bs[r + 1] - bs[r];
      start[r + 1] = start[r] + n;
    }
    const bool half = q.precision == ValuePrecision::kHalf;
    std::vector<std::uint32_t> column(start[rows_]);
    std::vector<float> values_f(half ? 0 : 3 * start[rows_]);
    std::vector<std::uint16_t> values_h(half ? 3 * start[rows_] : 0);
#pragma omp parallel for schedule(static)
    for (std::int64_t r = 0; r < rows_; ++r) {
      std::int64_t at = start[r];
      for (size_t b = 0; b < start_.size(); ++b)
        for (auto k = start_[b][r]; k < start_[b][r + 1]; ++k, ++at) {
          column[at] = column_[b][k];
          for (int ch = 0; ch < 3; ++ch) {
            const float v = value_[b][3 * k + ch];
            if (half)
              values_h[3 * at + ch] = float_to_half(v);
            else
              values_f[3 * at + ch] = v;
          }
        }
    }
    q.set_data(rows_, std::move(start), std::move(column), std::move(values_f),
               std::move(values_h));
    q.densify_if(0.75);
  }

  double dropped() const { return dropped_; }
  double total() const { return total_; }

 private:
  std::int64_t rows_;
  std::vector<std::vector<std::int64_t>> start_;
  std::vector<std::vector<std::uint32_t>> column_;
  std::vector<std::vector<float>> value_;
  double dropped_ = 0.0, total_ = 0.0;
};

// The operator's metadata before its values: kinds, columns, layout, where it came from.
SeriesOperator operator_shell(const TransportOperator& t, const World& world,
                              const SeriesOptions& o) {
  SeriesOperator q;
  q.output = o.output;
  q.basis = o.basis;
  q.precision = o.precision;
  q.columns = series_columns(world.patches(), world.scene(), o.basis);
  if (q.columns.empty())
    throw InputError("the scene has no emitting object: nothing to precompute");
  q.layout = t.layout();
  q.scene_file = world.scene().file;
  q.scene_hash = world.scene().hash;
  q.overrides = world.overrides();
  q.gather = o.gather;
  if (o.output == SeriesOutput::kView) {
    q.width = world.camera().width;
    q.height = world.camera().height;
  }
  return q;
}

void fill_report(SeriesReport& rep, const SeriesOperator& q, const TransportOperator& t,
                 const Terms& terms, const SeriesOptions& o, double rho, const RowPieces& rows) {
  rep.order = terms.order;
  rep.max_albedo = t.max_albedo();
  rep.apriori_bound = rep.max_albedo < 1.0
                          ? std::pow(rep.max_albedo, terms.order + 1) / (1.0 - rep.max_albedo)
                          : INFINITY;
  rep.aposteriori_estimate = terms.aposteriori;
  rep.spectral_radius = terms.spectral_radius;
  rep.term_norms = terms.norms;
  rep.acceleration = o.acceleration;
  rep.chebyshev_radius = o.acceleration == SeriesAcceleration::kChebyshev ? rho : 0.0;
  rep.residual_bound = terms.residual_bound;
  rep.dropped_energy = rows.dropped();
  rep.dropped_relative = rows.total() > 0.0 ? rows.dropped() / rows.total() : 0.0;
  rep.nnz = q.nnz();
  rep.bytes = q.bytes();
}

// The pixels of view rows: the given gather's, or the world camera's.
std::int64_t pixels(const World& world, const Gather* gather) {
  return gather ? static_cast<std::int64_t>(gather->width) * gather->height
                : static_cast<std::int64_t>(world.camera().width) * world.camera().height;
}

// P_K S of a batch of columns, kept in single precision until the gather reads it: every
// batch's is held at once, unknowns x 3 values a column (on the room's hierarchy, 570,000
// unknowns and 135 columns: 1.85 GB in doubles). The rounding, 6e-8 of each value, is far below the
// series' tolerance, and the rows are summed in double and stored in float (or half) anyway.
using KeptSum = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// The view rows of each column batch, Q = E S + G P_K S (papers/glossy-radiosity.md, eq. 12):
// sums[b] is P_K S of batch b, column_of[p] the column whose S lights patch p (or -1). The
// gather is read block by block, once for all batches; a deferred one's build time goes to the
// report.
std::vector<FieldBlock> view_rows(const Gather& gather, const std::vector<KeptSum>& sums,
                                  const std::vector<int>& column_of, int batch, std::int64_t rows,
                                  SeriesReport* report) {
  std::vector<FieldBlock> out;
  for (const auto& s : sums) out.push_back(FieldBlock::Zero(rows, s.cols()));
  const GatherWork work = for_each_gather_block(
      gather, kGatherBlockPixels, [&](std::int64_t r0, const Csr<Rgbf>& g, const Csr<Rgbf>& e) {
#pragma omp parallel for schedule(dynamic, 64)
        for (std::int64_t r = 0; r < g.rows; ++r) {
          for (size_t b = 0; b < sums.size(); ++b) {
            const Eigen::Index w = sums[b].cols();
            g.accumulate_row(r, sums[b].data(), w, out[b].data() + w * (r0 + r));
          }
          if (r >= e.rows) continue;
          for (auto [patch, value] : e.row(r)) {
            const int col = column_of[patch];
            if (col < 0) continue;  // not an emitter of any column: emits nothing in S
            double* y =
                out[col / batch].data() + out[col / batch].cols() * (r0 + r) + 3 * (col % batch);
            for (int ch = 0; ch < 3; ++ch) y[ch] += value[ch];
          }
        }
      });
  report->gather = gather_cost(gather, work);
  return out;
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

int series_batch(const SeriesOptions& o, double unknowns, double columns) {
  const double most = std::max(1, o.column_batch);
  const double fit = std::floor(o.batch_bytes / (kBatchBytes * std::max(1.0, unknowns)));
  const double width = std::clamp(fit, 1.0, most);
  const double batches = std::ceil(std::max(1.0, columns) / width);
  return static_cast<int>(std::ceil(std::max(1.0, columns) / batches));
}

double rows_memory(const SeriesOptions& o, double r, double u, double c) {
  // Counts in double: an absurd patch size must be refused, not overflow an integer first.
  const double value = o.precision == ValuePrecision::kHalf ? 6.0 : 12.0;
  const double batch = std::min(c, static_cast<double>(series_batch(o, u, c)));
  const double batch_blocks = u * kBatchBytes * batch;
  if (o.output == SeriesOutput::kView) {
    // Every batch's P_K S is kept, in floats, until the gather reads it. Beside them, first the
    // batch's blocks while the series runs, then the pixel rows and the rows kept (24 + 16 bytes an
    // entry; later the kept rows, Q and its dense copy: 16 + 2 x 12 at most): not both at once.
    // Summing the two stages gave 1.5 times the measured peak on the mirror cube, whose links
    // make its unknowns (18,312) twenty times its patches.
    return u * 3.0 * 4.0 * c + std::max(batch_blocks, r * c * 40.0);
  }
  // The batch's blocks, the rows kept, Q twice.
  return batch_blocks + r * c * (16.0 + 2.0 * value);
}

double rows_memory(const SeriesOptions& o, const Scene& scene) {
  double patches = 0.0, columns = 0.0;
  for (const FacePatches& f : face_patches(scene)) {
    patches += f.patches;
    if (o.basis == SeriesBasis::kPatch && scene.objects[f.object].is_emitter) columns += f.patches;
  }
  if (o.basis == SeriesBasis::kObject)
    for (const auto& obj : scene.objects) columns += obj.is_emitter ? 1.0 : 0.0;
  if (o.output == SeriesOutput::kSolution) return rows_memory(o, patches, patches, columns);
  const std::int64_t pixels = static_cast<std::int64_t>(scene.camera.width) * scene.camera.height;
  return rows_memory(o, static_cast<double>(pixels), patches, columns) +
         gather_memory(o.gather, pixels, true);
}

SeriesOperator precompute_series(const TransportOperator& t, const World& world,
                                 const SeriesOptions& o, const Gather* given_gather) {
  const Stopwatch watch;
  const bool view = o.output == SeriesOutput::kView;
  SeriesOperator q = operator_shell(t, world, o);
  const auto cols = static_cast<std::int64_t>(q.columns.size());
  std::unique_ptr<PermutedTransport> permuted = reordered_transport(t, o.reorder, q.report);
  auto unknown = [&](PatchId p) { return permuted ? permuted->permutation().position[p] : p; };
  const std::vector<std::vector<PatchId>> lit =
      lit_unknowns(q.columns, unknown_roots(t, world), world);

  Field s = Field::Zero(t.size(), 3);
  for (const auto& list : lit)
    for (PatchId p : list) s.row(p).setOnes();
  const bool chebyshev = o.acceleration == SeriesAcceleration::kChebyshev;
  double rho = o.chebyshev_radius;
  const Terms terms = chebyshev ? choose_chebyshev_order(t, s, o, &rho) : choose_order(t, s, o);

  const std::int64_t rows = view ? pixels(world, given_gather) : t.size();
  const std::vector<double>* flux = view ? nullptr : &t.flux_weight();
  RowPieces pieces(rows);
  const int batch = series_batch(o, static_cast<double>(t.size()), static_cast<double>(cols));
  Progress progress("series precompute", (cols + batch - 1) / batch * (terms.order + 1),
                    o.progress);
  // P_K S of each batch of columns. Solution rows are kept as they come; view rows wait for
  // the gather, which is then read once, block by block, for every batch (view_rows).
  std::vector<KeptSum> sums;
  BatchBlocks blocks;
  for (std::int64_t c0 = 0; c0 < cols; c0 += batch) {
    const int width = static_cast<int>(std::min<std::int64_t>(batch, cols - c0));
    blocks.term.setZero(t.size(), 3 * width);  // the same storage while the width is the same
    for (int c = 0; c < width; ++c)
      for (PatchId p : lit[c0 + c]) blocks.term.block(unknown(p), 3 * c, 1, 3).setOnes();
    progress.advance();
    // In the products' numbering; back in T's before the gather and the rows.
    FieldBlock original;
    if (permuted)
      original = permuted->to_original(
          block_polynomial(*permuted, blocks, terms.order, chebyshev, rho, progress));
    const FieldBlock& acc =
        permuted ? original : block_polynomial(t, blocks, terms.order, chebyshev, rho, progress);
    if (view)
      sums.push_back(acc.cast<float>());
    else
      pieces.add(acc, c0, width, q.columns, drop_thresholds(acc, width, o.drop, flux), flux);
  }
  blocks = BatchBlocks{};  // not held beside the gather's rows
  progress.finish();
  if (view) {
    const Gather gather = given_gather ? *given_gather
                                       : defer_gather(world, world.camera(), t.layout(), o.gather,
                                                      mesh_direct_for(o.gather, t, world));
    q.width = gather.width;  // a given gather may be of another camera than the world's
    q.height = gather.height;
    q.gather = gather.options;  // what made the rows
    const std::vector<int> column_of = patch_columns(q.columns, world);
    std::vector<FieldBlock> out = view_rows(gather, sums, column_of, batch, rows, &q.report);
    sums.clear();
    for (size_t b = 0; b < out.size(); ++b) {
      const int width = static_cast<int>(out[b].cols() / 3);
      const std::int64_t c0 = static_cast<std::int64_t>(b) * batch;
      pieces.add(out[b], c0, width, q.columns, drop_thresholds(out[b], width, o.drop, flux), flux);
      out[b] = FieldBlock();
    }
  }
  if (!view) q.direct = mesh_direct_for(o.gather, t, world);
  pieces.assemble(q);
  fill_report(q.report, q, t, terms, o, rho, pieces);
  q.report.seconds = watch.seconds();
  return q;
}

}  // namespace polyrad
