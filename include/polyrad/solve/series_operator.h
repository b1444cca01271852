// The stored operator of the precomputed series: Q with its metadata, and the one sparse product
// that relights with it (papers/glossy-radiosity.md, section 6).
//
//   Q = G P_K S,   out = Q e
//
// Columns: one per emitting patch (or per emitting object), S their unit emission; rows: the
// pixels of a camera (`view`, the gather G folded in) or every unknown (`solution`). e holds the
// RGB emission of each column; lights not named keep the scene's. Made by precompute_series
// (solve/series_precompute.h), stored and read back by io/prt_file.h (read by mmap, checked
// against its scene).
//
//   SeriesOperator q = read_prt("out/scene.prt");
//   std::vector<float> e = q.column_emission({{"light", Rgb(34, 24, 8)}});
//   std::vector<float> out(3 * q.rows());
//   q.apply(e.data(), out.data());
//   Image img = series_image(q, out);
//
// Cost: the product reads Q once: nnz(Q) (4 + 12) bytes in float, (4 + 6) in half, 12 (6)
// when dense; it is parallel over rows and allocates nothing.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "polyrad/render/camera_gather.h"
#include "polyrad/render/image.h"
#include "polyrad/transport/transport.h"
#include "polyrad/util/enum_names.h"
#include "polyrad/world/world.h"

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

template <>
struct EnumNames<SeriesOutput> {
  static constexpr const char* kind = "series output";
  static constexpr std::array<std::pair<SeriesOutput, const char*>, 2> table{
      {{SeriesOutput::kView, "view"}, {SeriesOutput::kSolution, "solution"}}};
};
template <>
struct EnumNames<ValuePrecision> {
  static constexpr const char* kind = "precision";
  static constexpr std::array<std::pair<ValuePrecision, const char*>, 2> table{
      {{ValuePrecision::kFloat, "float"}, {ValuePrecision::kHalf, "half"}}};
};
template <>
struct EnumNames<SeriesBasis> {
  static constexpr const char* kind = "basis";
  static constexpr std::array<std::pair<SeriesBasis, const char*>, 2> table{
      {{SeriesBasis::kPatch, "patch"}, {SeriesBasis::kObject, "object"}}};
};
template <>
struct EnumNames<SeriesAcceleration> {
  static constexpr const char* kind = "acceleration";
  static constexpr std::array<std::pair<SeriesAcceleration, const char*>, 2> table{
      {{SeriesAcceleration::kNone, "none"}, {SeriesAcceleration::kChebyshev, "chebyshev"}}};
};
template <>
struct EnumNames<SeriesReorder> {
  static constexpr const char* kind = "reorder";
  static constexpr std::array<std::pair<SeriesReorder, const char*>, 2> table{
      {{SeriesReorder::kNone, "none"}, {SeriesReorder::kRcm, "rcm"}}};
};

// What the precompute measured; written into reports and the .prt header.
struct SeriesReport {
  int order = 0;                      // K
  double max_albedo = 0.0;            // a_max of T
  double apriori_bound = 0.0;         // a^(K+1) / (1 - a): bound of the relative error
  double aposteriori_estimate = 0.0;  // ||T^K S|| q / (1 - q) / ||P_K S||, worst channel
  double spectral_radius = 0.0;    // q: the decay of the term norms (extrapolated), worst channel
  std::vector<double> term_norms;  // ||T^n S|| / ||S|| for n = 0..K (all columns together);
                                   // with Chebyshev, the residual ||S + T x_n - x_n|| / ||S||
  SeriesAcceleration acceleration = SeriesAcceleration::kNone;
  double chebyshev_radius = 0.0;  // rho used
  double residual_bound = 0.0;    // ||S + T x_K - x_K|| / (1 - a_max) / ||x_K||, worst channel
  double dropped_energy = 0.0;    // for the scene's emission: sum of dropped |Q e| (see below)
  double dropped_relative = 0.0;  // ... over the total
  long long nnz = 0;
  std::size_t bytes = 0;  // of the stored operator
  double seconds = 0.0;
  SeriesReorder reorder = SeriesReorder::kNone;
  long long bandwidth_before = 0;  // max |row - column| over T's stored entries, as built
  long long bandwidth_after = 0;   // ... in the numbering the products used (= before for kNone)
  double reorder_seconds = 0.0;    // ordering and the permuted copy of T (part of `seconds`)
  GatherWork gather;  // view rows: what building the gather cost (its seconds part of `seconds`)
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
// What an operator is, apart from its values: what its rows and columns are, where it came
// from and what its precompute measured. Reports carry it; the .prt header stores it.
struct SeriesMetadata {
  SeriesOutput output = SeriesOutput::kView;
  SeriesBasis basis = SeriesBasis::kPatch;
  ValuePrecision precision = ValuePrecision::kFloat;
  int width = 0, height = 0;  // view mode: the image
  std::vector<SeriesColumn> columns;
  GatherOptions gather;  // the gather that made (view) or will read (solution) the rows
  SeriesReport report;
  std::string scene_file;        // as given to the precompute (read_prt may be told another)
  std::uint64_t scene_hash = 0;  // Scene::hash of the scene it was made from
  SceneOverrides overrides;      // those the world was built with (to mesh it again the same)
};

class SeriesOperator : public SeriesMetadata {
 public:
  SeriesOperator() = default;
  SeriesOperator(SeriesOperator&&) noexcept = default;
  SeriesOperator& operator=(SeriesOperator&&) noexcept = default;

  UnknownLayout layout;  // solution mode: what each row is
  // Solution mode behind a final gather: the mesh's direct light (render/mesh_direct.h) that
  // the gather relight builds reads, for the lamps' mirror images and IndirectMode::kMesh, as
  // render's does (mesh_direct_for); null where that gather needs none.
  std::shared_ptr<const MeshDirect> direct;

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
  std::vector<float> column_emission(const std::map<std::string, Rgb>& lights = {}) const;
  // Names of the emitting objects, in column order.
  std::vector<std::string> light_names() const;

  // Storage: owned arrays, or pointers into a mapping kept alive by `keep`. Empty start and
  // column (null pointers) mean the dense layout.
  void set_data(std::int64_t rows, std::vector<std::int64_t> start,
                std::vector<std::uint32_t> column, std::vector<float> values_f,
                std::vector<std::uint16_t> values_h);
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

// The emission of each patch for column emission e (3 floats per column, as apply takes it):
// what a final gather reads beside a solution-mode product's Field (apply_gather). patches are
// the world's the operator was made on, scene its scene.
std::vector<Rgb> patch_emission(const SeriesMetadata& q, const std::vector<float>& e,
                                const PatchSet& patches, const Scene& scene);

// Image of a view-mode product (rows = pixels), or the Field of a solution-mode one.
Image series_image(const SeriesOperator& q, const std::vector<float>& out);
Field series_field(const SeriesOperator& q, const std::vector<float>& out);

}  // namespace polyrad
