// The precomputed truncated power series of the transport operator (papers/glossy-radiosity.md,
// section 6) and the single sparse product that relights with it.
//
//   Q = G P_K S,   P_K = sum_{n=0..K} T^n
//
// S: one column per emitting patch (unit emission), grouped by the emitting object's name.
// Rows: `view`, the pixels of the scene's camera through the gather G; or `solution`, every
// unknown (any camera afterwards needs only the gather). After the precompute, new lights cost
// one product, out = Q e, with e the RGB emission of each column.
//
//   SeriesOptions o;  o.tolerance = 1e-3;
//   SeriesOperator q = precompute_series(sys->transport, sys->patches, sys->scene, &gather, o);
//   std::vector<float> e = q.column_emission({{"light", Rgb(34, 24, 8)}});
//   std::vector<float> image(3 * q.rows());
//   q.apply(e.data(), image.data());
//
// Cost: precompute K sparse products over columns-wide blocks (O(K nnz(T) C) time, 3 blocks of
// unknowns x 3C doubles per column batch); the product reads Q once: nnz(Q) (4 + 12) bytes in
// float, (4 + 6) in half.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "polyrad/render/camera_gather.h"
#include "polyrad/scene/scene.h"
#include "polyrad/transport/transport.h"

namespace polyrad {

enum class SeriesOutput { kView, kSolution };
enum class ValuePrecision { kFloat, kHalf };
enum class SeriesBasis { kPatch, kObject };
// How the K applications of T combine: the truncated power series, or the Chebyshev
// semi-iteration, a different degree-K polynomial in T that converges like
// (rho / (1 + sqrt(1 - rho^2)))^K instead of rho^K when T's spectrum is real and within
// [-rho, rho] (as for diffuse scenes): far fewer terms as the albedo nears 1, and relighting
// stays one product.
enum class SeriesAcceleration { kNone, kChebyshev };
// How the precompute numbers T's unknowns for its block products: as built, or by reverse
// Cuthill-McKee for locality (reorder.h). Internal to the precompute: Q is the same either way.
enum class SeriesReorder { kNone, kRcm };
const char* series_output_name(SeriesOutput o);
const char* value_precision_name(ValuePrecision p);
const char* series_basis_name(SeriesBasis b);
const char* series_reorder_name(SeriesReorder r);

struct SeriesOptions {
  int order = -1;            // K; -1: the smallest K that meets `tolerance`
  double tolerance = 1e-3;   // relative error of the solution, flux-weighted 1-norm
  int max_order = 100000;
  double drop = 0.0;         // drop each column's smallest entries, up to this share of its energy
  ValuePrecision precision = ValuePrecision::kFloat;
  SeriesOutput output = SeriesOutput::kView;
  // One column per emitting patch (the default), or one per emitting object (its patches
  // together, as they always share the object's emission): far fewer columns, same answer
  // for any relighting that sets whole objects.
  SeriesBasis basis = SeriesBasis::kPatch;
  int column_batch = 64;     // columns computed together (bounds the memory)
  bool progress = true;      // a Progress display (when displays are enabled at all)
  SeriesAcceleration acceleration = SeriesAcceleration::kNone;
  // Chebyshev: the spectral radius rho; 0 estimates it from power steps (capped by a_max).
  double chebyshev_radius = 0.0;
  // kRcm: the K block products run on a copy of T renumbered by reverse Cuthill-McKee (S is
  // permuted in, each block's result back out before the rows are formed), for cache locality;
  // each row sums in T's order, so Q is the same bits. Not with on-the-fly link rows.
  SeriesReorder reorder = SeriesReorder::kNone;
};

// What the precompute measured; written into reports and the .prt header.
struct SeriesReport {
  int order = 0;                  // K
  double max_albedo = 0.0;        // a_max of T
  double apriori_bound = 0.0;     // a^(K+1) / (1 - a): bound of the relative error
  double aposteriori_estimate = 0.0;  // ||T^K S|| q / (1 - q) / ||P_K S||, worst channel
  double spectral_radius = 0.0;   // q: the decay of the term norms (extrapolated), worst channel
  std::vector<double> term_norms; // ||T^n S|| / ||S|| for n = 0..K (all columns together);
                                  // with Chebyshev, the residual ||S + T x_n - x_n|| / ||S||
  SeriesAcceleration acceleration = SeriesAcceleration::kNone;
  double chebyshev_radius = 0.0;  // rho used
  double residual_bound = 0.0;    // ||S + T x_K - x_K|| / (1 - a_max) / ||x_K||, worst channel
  double dropped_energy = 0.0;    // for the scene's emission: sum of dropped |Q e| (see below)
  double dropped_relative = 0.0;  // ... over the total
  long long nnz = 0;
  std::size_t bytes = 0;          // of the stored operator
  double seconds = 0.0;
  SeriesReorder reorder = SeriesReorder::kNone;
  long long bandwidth_before = 0; // max |row - column| over T's stored entries, as built
  long long bandwidth_after = 0;  // ... in the numbering the products used (= before for kNone)
  double reorder_seconds = 0.0;   // ordering and the permuted copy of T (part of `seconds`)
};

// One column of S: a unit emitter (a patch, or all patches of an object) and its scene emission.
struct SeriesColumn {
  std::string object;
  PatchId patch = -1;  // -1 in the object basis
  Rgb emission = Rgb::Zero();
};

// Q with RGB entries, owned or mapped from a file (prt_file.h). Stored dense (rows x columns,
// no indices: the product streams the values) when at least 3/4 of the entries are non-zero,
// as a view operator's are, else in compressed rows.
class SeriesOperator {
 public:
  SeriesOperator() = default;
  SeriesOperator(SeriesOperator&&) noexcept = default;
  SeriesOperator& operator=(SeriesOperator&&) noexcept = default;

  // Metadata.
  SeriesOutput output = SeriesOutput::kView;
  SeriesBasis basis = SeriesBasis::kPatch;
  ValuePrecision precision = ValuePrecision::kFloat;
  int width = 0, height = 0;      // view mode: the image
  std::vector<SeriesColumn> columns;
  UnknownLayout layout;           // solution mode: what each row is
  GatherOptions gather;           // the gather that made (view) or will read (solution) the rows
  SeriesReport report;
  std::string scene_file;
  std::uint64_t scene_hash = 0;
  double patch_size = 0.0;        // > 0: the patch size that overrode the scene's (meshing again)

  std::int64_t rows() const { return rows_; }
  std::int64_t cols() const { return static_cast<std::int64_t>(columns.size()); }
  bool dense() const { return start_ == nullptr; }
  // Stored entries (all rows x columns when dense).
  std::int64_t nnz() const { return dense() ? rows_ * cols() : (rows_ > 0 ? start_[rows_] : 0); }
  std::size_t bytes() const;

  // out (3 rows floats) = Q e, e: 3 floats per column. The one sparse product; parallel over
  // rows, nothing allocated.
  void apply(const float* e, float* out) const;

  // The emission of each column: the scene's, with the named objects set to new values.
  // Throws InputError for a name that is not an emitting object.
  std::vector<float> column_emission(const std::map<std::string, Rgb>& overrides = {}) const;
  // Names of the emitting objects, in column order.
  std::vector<std::string> light_names() const;

  // Storage: owned arrays, or pointers into a mapping kept alive by `keep`. Empty start and
  // column (null pointers) mean the dense layout.
  void set_data(std::int64_t rows, std::vector<std::int64_t> start, std::vector<std::uint32_t> column,
                std::vector<float> values_f, std::vector<std::uint16_t> values_h);
  void set_view(std::int64_t rows, const std::int64_t* start, const std::uint32_t* column,
                const void* values, std::shared_ptr<const void> keep);
  // Converts compressed rows to the dense layout when at least `fill` of the entries are stored.
  void densify_if(double fill);
  const std::int64_t* start() const { return start_; }
  const std::uint32_t* column() const { return column_; }
  const void* values() const { return values_; }

 private:
  std::int64_t rows_ = 0;
  const std::int64_t* start_ = nullptr;
  const std::uint32_t* column_ = nullptr;
  const void* values_ = nullptr;  // 3 floats or 3 halves per entry
  std::vector<std::int64_t> own_start_;
  std::vector<std::uint32_t> own_column_;
  std::vector<float> own_f_;
  std::vector<std::uint16_t> own_h_;
  std::shared_ptr<const void> keep_;
};

// The columns of S for a set of patches.
std::vector<SeriesColumn> series_columns(const PatchSet& patches, const Scene& scene,
                                         SeriesBasis basis);

// Runs the precompute. gather is required in view mode (its rows become Q's rows) and ignored
// in solution mode. Throws NumericalError if the term norms grow (the series diverges).
SeriesOperator precompute_series(const TransportOperator& t, const PatchSet& patches,
                                 const Scene& scene, const Gather* gather,
                                 const SeriesOptions& options);

// Image of a view-mode product (rows = pixels), or the Field of a solution-mode one.
Image series_image(const SeriesOperator& q, const std::vector<float>& out);
Field series_field(const SeriesOperator& q, const std::vector<float>& out);

}  // namespace polyrad
