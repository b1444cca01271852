// The transport operator T of u = e + T u, over exactly the unknowns the scene needs.
//
// Unknowns (papers/glossy-radiosity.md, section 3), one RGB value each:
//   u[i]      = B_i          diffuse radiosity of patch i, i in [0, N)      (emission included)
//   u[N + l]  = S_{i->k}     specular radiance of link l = (i -> k), l in [0, M)
// Radiance leaving i toward k is L_{i->k} = B_i + S_{i->k} (S = 0 where no link is stored).
//
// Rows (eq. 6 and 7), per colour channel c:
//   B_i       = E_i + d_i[c] * sum_j F_ij L_{j->i}
//   S_{i->k}  = s_i[c] * sum_j W_jik L_{j->i},   W_jik = R_jik F_ij / F_ik
// Both are "colour of the row times a sum of scalar weights times unknowns", so T is stored as
// one sparse matrix of float weights plus one colour per row, and a sweep is one pass over it
// for all three channels. A purely diffuse scene has M = 0: the classic radiosity system.
//
//   TransportOperator t = build_transport(patches, materials, ff, &specular);
//   Field u = t.emission();
//   Field next(u.rows(), 3);
//   t.apply(u, next);                      // next = T u
//
// Cost: memory 8 bytes per weight + 12 per row; apply() reads every weight once.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "polyrad/geometry/mesher.h"
#include "polyrad/raycast/ray_caster.h"
#include "polyrad/scene/brdf.h"
#include "polyrad/transport/form_factors.h"
#include "polyrad/transport/specular_transfer.h"
#include "polyrad/util/sparse.h"

namespace polyrad {

// One RGB value per unknown, rows in unknown order.
using Field = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
// Several fields side by side: row r holds [col0 rgb, col1 rgb, ...] (3 C values).
using FieldBlock = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

class HierarchicalOperator;  // transport/hierarchy.h
class ElementHierarchy;

struct Link {
  PatchId from = 0;  // i
  PatchId to = 0;    // k
};

// Section 4.1: the specular rows recomputed from the transfer estimator at every application
// instead of stored. The same seeds give the same numbers; the cost moves from memory (no W) to
// time (every sweep traces the transfer's rays again). Everything pointed to must outlive T.
struct OnTheFlySpecular {
  const PatchSet* patches = nullptr;
  const std::vector<Material>* materials = nullptr;
  const FormFactors* ff = nullptr;
  const RayCaster* caster = nullptr;
  SpecularOptions options;
};

// Which unknown holds what: B_i at index i, S_{i->k} at num_patches + l. Enough to read, store
// or gather a solution without the operator itself.
struct UnknownLayout {
  int num_patches = 0;
  std::vector<Link> links;               // sorted by (from, to)
  std::vector<std::int64_t> link_start;  // links of patch i: [link_start[i], link_start[i+1])
  // Flux per unit radiance of each unknown: pi A'_i for B_i (A' the exposed area),
  // tau_ik = pi A'_i F_ik for S_{i->k}. In these weights every column of T sums to at most the
  // largest albedo (section 5).
  std::vector<double> flux_weight;
  // Set when the B unknowns are the leaves of an element hierarchy (transport/hierarchy.h):
  // B_l is then the radiosity of leaf l, and a point of a patch reads the leaves under it.
  std::shared_ptr<const ElementHierarchy> hierarchy;

  Eigen::Index size() const { return num_patches + static_cast<Eigen::Index>(links.size()); }
  // Index of the unknown S_{i->k}, or -1 if that link carries no specular radiance.
  Eigen::Index link_unknown(PatchId i, PatchId k) const;
};

class TransportOperator {
 public:
  const UnknownLayout& layout() const { return layout_; }
  int num_patches() const { return layout_.num_patches; }
  int num_links() const { return static_cast<int>(layout_.links.size()); }
  Eigen::Index size() const { return layout_.size(); }
  const std::vector<Link>& links() const { return layout_.links; }
  Eigen::Index link_unknown(PatchId i, PatchId k) const { return layout_.link_unknown(i, k); }

  const Csr<float>& weights() const { return weights_; }
  const std::vector<Eigen::Array3f>& row_colour() const { return row_colour_; }
  const std::vector<double>& flux_weight() const { return layout_.flux_weight; }

  // e: the patches' emission in the B rows, zero elsewhere.
  Field emission() const;
  Field emission(const std::vector<Rgb>& patch_emission) const;

  // out = T in, for one field or a block of fields. in and out must not alias.
  void apply(const Field& in, Field& out) const;
  void apply(const FieldBlock& in, FieldBlock& out) const;
  // out = T_c in for one colour channel c (the operator of that channel alone).
  void apply_channel(const double* in, double* out, int channel) const;
  // One Gauss-Seidel sweep in place: u[r] = e[r] + (T u)[r], rows in order.
  void gauss_seidel_sweep(const Field& e, Field& u) const;

  // The flux-weighted 1-norm of a field, summed over channels (section 5), and per channel.
  // flux_norm takes an expression too (flux_norm(u - previous)), read row by row without a
  // field of its own: a solve's convergence test allocated one each sweep (14 MB on the room).
  template <typename Derived>
  double flux_norm(const Eigen::MatrixBase<Derived>& f) const {
    double s = 0.0;
    for (Eigen::Index r = 0; r < f.rows(); ++r)
      s += layout_.flux_weight[r] * f.row(r).cwiseAbs().sum();
    return s;
  }
  Eigen::Array3d flux_norm_channels(const Field& f) const;
  // Memory of the stored operator, in bytes, by part.
  std::size_t bytes() const;
  std::int64_t nnz_diffuse() const { return nnz_diffuse_; }
  std::int64_t nnz_specular() const { return weights_.nnz() - nnz_diffuse_; }
  // The largest albedo bound over the materials that reflect (a_max of section 5).
  double max_albedo() const { return max_albedo_; }
  // The material with that albedo bound: the likely culprit when the iteration diverges.
  const std::string& brightest_material() const { return brightest_material_; }
  // A sentence naming that material when its bound exceeds 1 (empty otherwise), for messages.
  std::string divergence_hint() const;
  bool on_the_fly() const { return on_the_fly_ != nullptr; }
  // The unknowns are the leaves of an element hierarchy (transport/hierarchy.h): apply,
  // Gauss-Seidel and the channel product go through its pull, link and push passes; nothing is
  // in weights().
  bool hierarchical() const { return hierarchy_ != nullptr; }
  const HierarchicalOperator* hierarchy() const { return hierarchy_.get(); }
  // A guess of the solution for the emission, where the build has one (a hierarchy's last
  // solve between passes); nullptr otherwise. For SolveOptions::start.
  const Field* solution_guess() const;

 private:
  friend TransportOperator build_transport(const PatchSet&, const std::vector<Material>&,
                                           const FormFactors&, const SpecularTransfer*,
                                           const OnTheFlySpecular*);
  friend TransportOperator hierarchical_transport(std::shared_ptr<const ElementHierarchy>,
                                                  const std::vector<Material>&);
  std::shared_ptr<const HierarchicalOperator> hierarchy_;
  // Link rows from the estimator: out[link rows] = (e +) colour * sum w x, x = in (or out itself,
  // in place, for Gauss-Seidel); width values per row.
  void recompute_link_rows(const double* in, double* out, Eigen::Index width, bool in_place,
                           const Field* e) const;
  std::shared_ptr<const OnTheFlySpecular> on_the_fly_;
  UnknownLayout layout_;
  Csr<float> weights_;
  std::vector<Eigen::Array3f> row_colour_;
  std::vector<Rgb> patch_emission_;
  std::int64_t nnz_diffuse_ = 0;
  double max_albedo_ = 0.0;
  std::string brightest_material_;
};

// out = diag(row_colour) W in over W's stored rows, for a block of fields; each row sums its
// entries in stored order. T's product on blocks, and its renumbered copy's
// (permuted_transport.h).
void apply_weighted_rows(const Csr<float>& weights, const std::vector<Eigen::Array3f>& row_colour,
                         const FieldBlock& in, FieldBlock& out);

// Which links i -> k carry specular radiance (section 3): the fixed point over the transfer's
// entries (j, i, k) whose source can be bright, B_j of an emitter or of a diffuse reflector, or
// an active link j -> i. Sorted by (from, to). build_transport's links, and the hierarchy's
// (hierarchy.h, section 12.6), which runs it on its roots.
std::vector<Link> active_specular_links(const PatchSet& patches,
                                        const std::vector<Material>& materials,
                                        const FormFactors& ff, const SpecularTransfer& st);

// Builds T from the form factors and, if given, the specular transfer (which also decides the
// links). With on_the_fly the link rows are not stored but recomputed at every application.
// Materials are indexed by Patch::material.
TransportOperator build_transport(const PatchSet& patches, const std::vector<Material>& materials,
                                  const FormFactors& ff, const SpecularTransfer* specular,
                                  const OnTheFlySpecular* on_the_fly = nullptr);

}  // namespace polyrad
