// Hierarchical links (Hanrahan, Salzman and Aupperle 1991): each patch of the uniform mesh is
// the root of an element tree, and light moves along links between elements at whatever level
// its error estimate allows, so a scene costs links about linear in its elements instead of the
// uniform mesh's N^2 pairs (papers/glossy-radiosity.md, section 12).
//
// Elements. A root is a patch of the uniform mesh at the scene's patch_size, the largest element
// size. A quad splits bilinearly into four (at the midpoints of its parameters), a triangle into
// four at its edge midpoints. No element is split below min_element_size.
//
// Links. A link joins two elements a and b of different trees and carries light both ways with
// one etendue G_ab = A'_a F_ab = A'_b F_ba (eq. 4; A' the exposed area). Along a link, the form
// factor is taken as linear over each end (in its root's parameters): F_ab plus the slopes of
// the unoccluded point form factors (eq. 5) at the corners. A receiver spreads what it gathers
// by that linear function, and each part of a source sends by the form factor at its own place
// (through the source's first moments). With a constant per link instead, a leaf at a wall took
// every coarse link's average, which near the wall errs with one sign link after link: up to half
// again too much light at the Cornell box's edges.
//
// The oracle (section 12, eq. H1), per direction r <- s and channel c, against what r receives:
//   - wholly visible: what the linear function misses of the point values at r's corners and
//     centre, dF_rs, within the tolerance's share of what the link carries:
//         rho_r B_s dF_rs <= tau rho_r F_rs max(B_s, B_ref / 4)
//     so the misses of all the links a leaf reads add up to about tau of its light; or the link
//     carries a negligible share of r's light: rho_r B_s F_rs <= tau max(B_r, B_ref / 4) / 10.
//     B_ref is the scene's mean reflected radiosity (first estimated as the mean emission over
//     one minus the mean reflectance, then measured on each solve): sources and receivers
//     darker than a quarter of it count as that bright;
//   - not yet tested by rays: the same with dF = F_max (a pair is linked without rays only then);
//   - partly hidden (some of visibility_rays rays blocked): the shadow may put all of it
//     anywhere: rho_r B_s F_max <= tau max(B_r, B_ref / 4), a share of r's own radiosity (the
//     point values, weighed by visible fractions from four rays each, shape its linear
//     functions but are too noisy to judge them by);
//   - hidden (every ray blocked): linked as it is, never refined.
// A pair links at the coarsest level where both directions pass; otherwise the larger element
// splits and its children are judged (the parts of a wholly visible pair inherit its
// visibility). The first pass knows only the emission (B = E: only the lights' links refine);
// each later pass solves, then judges every link again with the new radiosities.
//
// The operator on the leaves. One application of T (eq. H2), for leaf radiosities x, y the root
// parameters, y_n the area centroid of node n:
//     m_n = sum_{leaves l under n} (A'_l / A'_n) c_l x_l,        pull: every node's area mean
//     q_n = sum_{leaves l under n} (A'_l / A'_n) c_l x_l (y_l - y_n)   and first moments
//     H_r(y) = sum_{links r <- s} (F_rs m_s + c_rs . q_s + g_rs . (y - y_r) m_s)    gather
//     (T x)_l = rho_l sum_{nodes r above l, l included} H_r(y_l)   push: each ancestor's
//                                                                linear function at l
// with g_rs the receiver slopes and c_rs = (A'_s / A'_r) g_sr. It is linear in x and stays
// factored (a tree, the link rows, a tree): never a leaf x leaf matrix. The slopes are shrunk
// together where the kernel they make could go negative over the boxes of the leaves' centroids
// under the link's ends (T reads it at those centroids alone; with a margin of 1e-5), so T is
// non-negative, and
// a linear function's area mean over the children is its value at their area centroids, so each
// link delivers exactly its etendue's flux: in flux form (weights pi A'_l) the column of leaf l
// sums to sum_{s above l} sum_{r <- s} rho_r (F_sr + g_sr . (y_l - y_s)). Near contacts, where
// the linear functions are too coarse, those form factors sum above 1; c_l, the energy guard,
// scales the leaves whose column (each receiver weighed by its albedo bound, d + s) would then
// exceed a_max down to it, so every column of T sums to at most a_max: section 5's bound, the
// Jacobi = series identity and the precompute hold unchanged. What it takes it gives back to the
// other leaves of the same tree whose form factors sum below 1 (c_l > 1, up to their own flux
// and the bound), so each tree shoots the flux its links' etendues carry. It scales no leaf
// whose column is within the bound, so a tree of one level, where the uniform mesh keeps the
// bound, is that mesh.
//
// Lobes (eq. H3, RootSpecular below): mirror, glossy and Phong light moves on link unknowns
// S_{i->k} between ROOTS, with the uniform mesh's transfer computed on the roots (once, after
// the first pass); the element links carry B_s + S_{root(s)->root(r)}, so the leaves receive
// specular light as they receive diffuse light, and a reflector's rows read what its tree's
// links bring from each root. The solves between passes carry the links; the oracle judges a
// reflector's source end by B + S and its receiving end by d + s. Unknowns: the leaves, then
// the links.
//
// Image links (eq. H4, options.mirror_links; section 12.8): what a planar mirror q shows a
// receiver without a lobe goes on links between elements r and s seen in q, s at its mirror image
// through q's outline, refined by the same oracle, so a mirror's light falls where the image of
// its source does instead of one value per pair of roots. Such a link carries
// s_q (B_s + S_{root(s)->m}) (m the mirror root its path crosses) toward its ends without a
// lobe; the root links S_{m->k} toward receivers without a lobe are then left out of T (kept,
// unfed, for the gathers, which read through those mirrors instead). Form factors exact through
// the outline; visibility by rays with two segments, via the mirror.
//
//   ElementHierarchy h = build_hierarchy(patches, scene.materials, caster, {});
//   TransportOperator t = hierarchical_transport(h, scene.materials);   // leaves, then links
//   (h a std::shared_ptr<const ElementHierarchy>: the operator's layout keeps it)
//   SolveResult r = solve(t, t.emission());
//   LeafPoint p = h.leaf_at(hit.patch, hit.u, hit.v);                   // what a hit reads
//
// Cost: the first pass tests every pair of roots (R^2 / 2 facing tests and point form factors);
// refinement costs ten point form factors and at most visibility_rays rays per candidate (n^2
// times that between elements over 8 (n - 1) smallest elements long, n <= 4: visibility_rays), and
// each link one pair form factor (eq. 4, as the uniform mesh; with open_link_rays shadow rays
// per point where the oracle saw no shadow below the roots). Memory: about 420 bytes per
// element (352 its Element, 64 leaf_at's copy) and at most 1 KiB per root (leaf_at's grid), 32
// per link between passes (its oracle values in 8-bit fractions), 12 once built and 48 in T (both
// directions, five floats and an index each); one application reads every link twice and each tree
// three times. Lobes add the uniform mesh's transfer on the roots (2 x samples rays per facing pair
// into a reflector), 8 bytes per entry of a root link's row and 4 per element link entry of the
// trees that reflect or receive specular light. Image links add R^2 / 2 pair tests per mirror
// plane, a clip and a point form factor per oracle point and per Gauss point (9 a link), 2 rays
// per visibility ray, and per entry in T 24 bytes plus 9 (its plane, mirror root and link).
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "polyrad/geometry/mesher.h"
#include "polyrad/raycast/ray_caster.h"
#include "polyrad/scene/brdf.h"
#include "polyrad/transport/form_factors.h"
#include "polyrad/transport/mirror_planes.h"
#include "polyrad/transport/transport.h"

namespace polyrad {

// The sample points of an element at which the oracle evaluates point form factors.
inline constexpr int kOraclePoints = 5;

// The most mirror planes image links go through (the first ones of mirror_planes; the light of
// any others stays on the specular links).
inline constexpr int kMaxMirrorPlanes = 255;

// The link tolerance where none is chosen and no gather reads the solution.
inline constexpr double kDefaultLinkTolerance = 0.05;

struct HierarchyOptions {
  // tau of eq. H1 (above): the error a link may make, as a fraction of what it carries (or, for
  // a partly hidden pair, of its receiver's radiosity). 0: not chosen; render and precompute
  // then take what their gather needs (link_tolerance_for, render/camera_gather.h), anything
  // else kDefaultLinkTolerance.
  double link_tolerance = 0.0;
  // No element is split into children with an edge shorter than this (scene units); 0: an
  // eighth of the root's longest edge (three levels).
  double min_element_size = 0.0;
  // Refinement passes after the first; each solves and refines with the new radiosities.
  int passes = 2;
  // The relative change at which a solve between passes stops (Gauss-Seidel on the hierarchy).
  double pass_tolerance = 1e-3;
  // Rays between the two elements of a pair whose error asks for the visibility test, for
  // elements up to eight smallest elements long; a larger one is cut into n x n parts so long
  // (n at most 4) and each gets as many (a wholly visible verdict is kept by the pair's parts: a
  // few rays between whole walls missed a block's shadow). At the default smallest size, this.
  int visibility_rays = 16;
  // Scale the leaves whose column would sum above a_max (see above); off only to compare.
  bool energy_guard = true;
  // The pair form factor of each link (eq. 4), as the uniform mesh computes it ...
  FormFactorOptions form_factors;
  // ... but with this many shadow rays per quadrature point (form_factors.visibility_rays
  // elsewhere) on a link below the roots where the oracle saw no shadow: every one of its rays
  // open, or linked without rays since all of the pair's light is within the tolerance (judged
  // again later and found shadowed, it is integrated again with the full count). Exact where
  // the pair is wholly visible or hidden; in a penumbra a point's one ray estimates the share
  // of the other element it sees by area rather than weighed by the kernel, which over a small
  // element hardly differs, with more noise. The rays go where the oracle saw shadows. Root
  // pairs keep the uniform mesh's count, so that a tree of one level reproduces the uniform
  // system exactly. At least 1 (0 is taken as 1: a pair the oracle's few rays saw open may
  // still be partly hidden), at most form_factors.visibility_rays.
  int open_link_rays = 1;
  std::uint64_t seed = 5;  // the oracle's visibility rays
  // Lobes (eq. H3): the transfer on the roots, computed once after the first pass; off, every
  // material is reduced to its diffuse part.
  bool specular_links = true;
  SpecularOptions specular;
  // Image links (eq. H4, above): what a planar mirror shows a receiver without a lobe goes on
  // links to the mirror images of the sources, refined by the oracle; off, on the specular links
  // between the roots. Only with specular_links.
  bool mirror_links = false;
  // What the links may hold, in bytes at kLinkBytesFloor a link (0: no limit): refinement that
  // keeps more links than that stops with an InputError (exit code 2) instead of running out of
  // memory, since how far the light asks it to refine is known only as it goes. build_system
  // sets it: the memory budget less the estimate's process, world and camera.
  double max_link_bytes = 0.0;
  static constexpr double kLinkBytesFloor = 100.0;
  double tolerance() const { return link_tolerance > 0.0 ? link_tolerance : kDefaultLinkTolerance; }
  // The smallest element under a root whose longest edge is `root_edge` (min_element_size's
  // rule, above).
  double smallest_element(double root_edge) const {
    return min_element_size > 0.0 ? min_element_size : root_edge / 8.0;
  }
};

// One node of an element tree.
struct Element {
  Patch shape;  // geometry, object, material, emission; bend is the root's
  PatchId root = 0;
  std::int32_t parent = -1;
  std::int32_t first_child = -1;  // children are 4 consecutive elements; -1 for a leaf
  std::int32_t leaf = -1;         // the unknown of a leaf, -1 for an inner node
  std::int32_t level = 0;
  // The corners' parameters on the root (Patch::point), in the order of shape.corner.
  std::array<Vec2, 4> uv{};
  Vec2 centroid_uv = Vec2::Zero();  // its area centroid in the root's parameters
  double exposed = 0.0;             // A': exposed area; a node's is the sum of its children's
  std::uint64_t key = 0;  // from the root and the path to the element: keys random streams
  bool is_leaf() const { return first_child < 0; }
};

// A link of the finished hierarchy: elements a and b and one pair form factor for both
// directions, F_ab = m (the mean over a's exposed points of the point form factor to b) and
// F_ba = m A'_a / A'_b. What the oracle measured on it while refining (point values, rays) is
// dropped when the build ends: 32 bytes a link between passes, 64 while a link is judged.
struct LinkedPair {
  std::int32_t a = 0, b = 0;
  float m = 0.0f;
};

// An image link: b seen from a in mirror plane `plane` (and a from b), F_ab = m the mean over
// a's exposed points of the point form factor to b's image through the mirror.
struct ImageLink {
  LinkedPair pair;
  std::int32_t plane = 0;
};

// A point of a root patch located on its leaf.
struct LeafPoint {
  std::int32_t element = -1;  // the leaf element
  std::int32_t leaf = -1;     // its unknown
  double s = 0.0, t = 0.0;    // parameters on the leaf (Patch::point of its shape)
  double diameter = 0.0;      // the leaf's (Patch::diameter of its shape)
};

struct HierarchyPass {
  long long candidates = 0;  // pairs the oracle judged
  long long visibility_tests = 0;
  long long splits = 0;  // elements split
  long long links = 0;   // links after the pass
  long long elements = 0, leaves = 0;
  int sweeps = 0;  // Gauss-Seidel sweeps of the solve that ended the pass
  // The oracle (judging, splitting, and in a later pass judging the kept links again), the
  // links' pair form factors, the operator of the pass's links (its rows and energy guard) and
  // the solve that ends it.
  double oracle_seconds = 0.0, form_factor_seconds = 0.0, operator_seconds = 0.0,
         solve_seconds = 0.0;
};

struct HierarchyStats {
  double b_ref_estimate = 0.0;  // the first pass's B_ref: mean emission / (1 - mean reflectance)
  double b_ref = 0.0;           // the last pass's: the mean radiosity of the last solve
  double link_tolerance = 0.0;  // tau, as used
  double min_element_size = 0.0;
  double exposure_seconds = 0.0;
  long long root_pairs_facing = 0;
  long long oracle_rays = 0, form_factor_rays = 0, exposure_rays = 0;
  std::vector<HierarchyPass> passes;
  // The energy guard: how far the leaves' columns it bounds exceeded a_max before it (a fraction
  // of a_max), and on how many leaves it acted.
  double guard_max_excess = 0.0;
  long long guard_leaves = 0;
  // The specular part (eq. H3): the root form factors' and the transfer's seconds, the
  // transfer's entries, the root links and their rows' entries.
  double root_form_factor_seconds = 0.0, transfer_seconds = 0.0, specular_link_seconds = 0.0;
  long long transfer_entries = 0, specular_links = 0, specular_row_entries = 0;
  // Image links (in passes[].links too) and the mirror planes they go through.
  long long image_links = 0, mirror_planes = 0;
  long long root_form_factors = 0;  // non-zeros of the reflectors' rows
  double lookup_seconds = 0.0;      // the final gather's lookups: corner averages, leaf grids
  double seconds = 0.0;
};

// The specular part of the hybrid (section 12.6, eq. H3): link unknowns S_{i->k} between ROOTS,
// i a root whose material has a lobe, k a root it sends specular light to, with the uniform
// mesh's transfer R_jik computed on the roots (specular_transfer.h) from root form factors that
// are the sums of the etendues of the links between the two trees (root_form_factors). Two
// couplings join it to the leaves, both along the element links, which carry
// L_{s->r} = B_s + S_{root(s)->root(r)}:
//   (a) receive: a node r of root k gathers F_rs S_{j->k} (and its slopes g_rs S_{j->k}) along
//       each of its links r <- s with s in the tree of reflector j, so the specular light is
//       spread over k's leaves as the diffuse light from j is; the links' etendues sum to
//       A'_k F_kj, so k receives exactly the flux tau_jk S_{j->k};
//   (b) reflect: the specular rows read what arrives at i from root j along the links of i's
//       tree, not B_j at the root's mean:
//           I_ij = sum_{nodes r of i} (A'_r / A'_i) sum_{links r <- s, s in j} (F_rs m_s + c_rs .
//           q_s) S_{i->k} = s_i sum_j (R_jik / F_ik) (I_ij + F_ij S_{j->i})
//       (with leaves constant over j, I_ij = F_ij B_j and this is eq. 7).
// Why it keeps section 5's bound: each unit of flux that reaches reflector i along a link is
// split into d_i (its leaves' diffuse rows, eq. H2) and s_i sum_k R_jik <= s_i (its links), so a
// leaf's column is the form factors from its place, each weighed by its receiver's
// d + s sum_k R <= d + s, a sum the guard holds to a_max; a link's column is d_k + s_k sum R <=
// a_max likewise.
struct RootSpecular {
  // The link unknowns (unknown leaves + l), sorted by (from, to) over root ids; the links of
  // root i are [link_start[i], link_start[i + 1]).
  std::vector<Link> links;
  std::vector<std::int64_t> link_start;
  std::vector<double> flux_weight;     // tau_ik = pi A'_i F_ik of each link
  std::vector<Eigen::Array3f> colour;  // s_i of each link's reflector
  // The reflector roots that have links, each with its pairs (i, j): the roots j whose trees
  // share links with i's, in ascending j: [pair_start[x], pair_start[x + 1]) for reflector x.
  std::vector<std::int32_t> reflector;
  std::vector<std::int64_t> pair_start;
  std::vector<std::int32_t> pair_source;  // j
  std::vector<float> pair_f;              // F_ij, the root form factor
  std::vector<std::int64_t> pair_link;    // the link index of S_{j->i}, -1 if none
  // sum over i's links k of R_jik (colour excluded), the links that read only links left out
  std::vector<float> pair_reflected;
  // Per link: 1 for a planar mirror's link toward a root without a lobe, which the image links
  // stand for (eq. H4): kept for the gathers that read it, but no longer fed or read by T.
  std::vector<char> links_only;
  // Per entry of the image links' rows: the link S_{root(s)->m} that the source s sends toward
  // the mirror root m the entry's path crosses, -1 for none (eq. H4).
  std::vector<std::int32_t> image_link;
  // For each link entry of the rows of reflector x's tree nodes (in the operator's link rows,
  // from the first node's first entry on), its local pair index: entry_start[x] + offset.
  std::vector<std::int64_t> entry_start;
  std::vector<std::int32_t> entry_pair;
  Csr<float> rows;  // row l: (local pair q of l's reflector, R_jik / F_ik)
  // (a): for each tree k that receives specular light (a root with a diffuse part that some
  // link reaches), the link S_{root(s)->k} of each entry r <- s of its nodes' rows, -1 for none:
  // receive_entry[receive_start[k] + offset]; receive_start[k] = -1 for the other trees.
  std::vector<std::int64_t> receive_start;
  std::vector<std::int32_t> receive_entry;
  std::int64_t max_pairs = 0;  // the most pairs of one reflector (its gather buffer)

  std::int64_t num_links() const { return static_cast<std::int64_t>(links.size()); }
  std::size_t bytes() const;
};

// The operator of eq. H2 on the leaves (see the top of this file), with the root link unknowns
// of eq. H3 after them when the scene has lobes. Immutable once built but for the node buffers
// it reuses (below); what TransportOperator holds and forwards to when its unknowns are a
// hierarchy's leaves.
class HierarchicalOperator {
 public:
  Eigen::Index leaves() const { return static_cast<Eigen::Index>(leaf_node_.size()); }
  Eigen::Index nodes() const { return static_cast<Eigen::Index>(parent_.size()); }
  // Unknowns: the leaves, then the specular links.
  Eigen::Index size() const { return leaves() + (specular_ ? specular_->num_links() : 0); }
  std::int64_t link_entries() const { return links_.nnz(); }
  const RootSpecular* specular() const { return specular_.get(); }

  // out = T in (eq. H2, H3), width values per unknown (a Field: 3; a block: 3 C; one channel:
  // 1, then `channel` picks the reflectance). in and out must not alias.
  void apply(const double* in, double* out, Eigen::Index width, int channel = -1) const;
  // The image links' part of apply (eq. H4), on the leaves alone: out (leaves x width) = what
  // in's leaves and links send along the image links, reflected by the receiving leaves.
  void apply_images(const double* in, double* out, Eigen::Index width) const;
  // One Gauss-Seidel sweep, root tree by root tree: each tree gathers from the current values
  // of every other (its own links never reach itself) and the current specular links, then
  // pushes, reflects and pulls again; then the reflectors' link rows in order. The trees go in
  // 16 waves of about equal link entries, the reflectors likewise: a wave's members run on every
  // thread and read the values as the wave found them (Jacobi inside a wave), so the sweep is
  // the same on any thread count. On the room, the first pass's solve takes 9 sweeps in 0.55 to
  // 0.60 s, against 8 in 0.56 to 0.77 s one tree at a time (2 threads, single runs).
  void gauss_seidel_sweep(const Field& e, Field& u) const;
  // Flux-form column sums of T per leaf, the largest channel's (with reflectance = false, the
  // form factors' alone), with or without the guard. A reflector's receivers count
  // d + s sum_k R_jik.
  std::vector<double> column_sums(bool with_guard, bool reflectance = true) const;
  // The same without the guard, each link entry r <- s (tree t, entry e of the link rows)
  // weighed by albedo(t, e): what the guard bounds (a bound of every channel's reflectance);
  // with images, each image link entry weighed by its receiver's reflectance times s_q.
  std::vector<double> column_sums_by(
      const std::function<Eigen::Array3d(std::int32_t, std::int64_t)>& albedo,
      bool images = true) const;
  // What entry `entry` of tree t's link rows counts in a column: rho_t, plus for a reflector's
  // tree its colour times sum_k R_jik over its links that read the leaves (eq. H3 (b)), j the
  // entry's source root.
  Eigen::Array3d entry_albedo(std::int32_t t, std::int64_t entry,
                              const Eigen::Array3d& rho_t) const;
  // The diffuse reflectance of each tree's leaves, as T applies it.
  std::vector<Eigen::Array3d> tree_reflectance() const;
  std::size_t bytes() const;

 private:
  friend class HierarchyBuilder;
  friend class ElementHierarchy;
  friend RootSpecular build_root_specular(const ElementHierarchy&, const std::vector<Material>&,
                                          const FormFactors&, const SpecularTransfer&);
  // Per image entry, the link its source sends toward the mirror (RootSpecular::image_link).
  const std::int32_t* image_entry_links() const {
    return specular_ && !specular_->image_link.empty() ? specular_->image_link.data() : nullptr;
  }
  // Every tree's pull of in (width values per leaf) into b, on every thread.
  void pull_all(const double* in, Eigen::Index width, double* b) const;
  // (a) of eq. H3 into the gathered functions h of the root nodes of trees [first, last).
  void receive_specular(const double* s, Eigen::Index width, std::int32_t first_tree,
                        std::int32_t last_tree, double* h) const;
  // A sweep's wave of trees [first, last) (inside its parallel region), and its reflectors.
  void sweep_wave(std::int32_t first, std::int32_t last, const Field& e, Field& u, double* b,
                  double* h) const;
  void sweep_reflectors(const Field& e, Field& u, const double* b) const;
  // (b) of eq. H3 for reflector x: its link rows from the pulled values b and the links s,
  // written to out (colour, or one channel's); lin holds max_pairs x width doubles.
  void specular_rows(std::int64_t x, const double* b, const double* s, Eigen::Index width,
                     int channel, double* lin, double* out) const;
  std::shared_ptr<const RootSpecular> specular_;
  // Nodes in pre-order, tree after tree: a parent before its children.
  std::vector<std::int32_t> parent_;
  std::vector<float> share_;             // A'_n / A'_parent(n), the pull weight (0 at a root)
  std::vector<std::int32_t> node_leaf_;  // the unknown of a leaf node, -1 otherwise
  std::vector<std::int32_t> leaf_node_;  // the node of each unknown
  std::vector<std::int32_t>
      tree_start_;                   // nodes of root tree k: [tree_start_[k], tree_start_[k+1])
  std::vector<Eigen::Array3f> rho_;  // per leaf
  std::vector<float> guard_;         // c_l per leaf (1 without the guard)
  std::vector<double> exposed_;      // A' per node
  // Row r: (s, {F_rs, g_rs, c_rs}) of every link r <- s: the mean F_rs; g_rs (u and v) the
  // slopes over r, in its root's parameters, of the linear function by which r's part is spread
  // over its leaves; c_rs = (A'_s / A'_r) g_sr, which weights the source's first moments, so
  // that each leaf of s sends along the link by the form factor at its own place.
  Csr<std::array<float, 5>> links_;
  // The image links' rows (eq. H4), as links_, each entry's mirror plane in image_plane_, the
  // root of that plane its path crosses in image_root_, and the planes' colours s_q in
  // plane_colour_.
  Csr<std::array<float, 5>> images_;
  std::vector<std::uint8_t> image_plane_;
  std::vector<std::int32_t> image_root_;
  std::vector<Eigen::Array3f> plane_colour_;
  std::vector<std::array<float, 2>> centroid_;  // each node's centroid_uv

  // The pulled and gathered values of every node (3 x width doubles each, b and h) that apply()
  // and gauss_seidel_sweep() work in: kept from call to call, with the widest call's size, since
  // a solve or a precompute applies the operator hundreds of times and polyrad has glibc map
  // every block of 256 KiB or more afresh (util/machine.h), so new buffers page-faulted in
  // every call (paired runs of the mirror cube's hierarchical precompute: 13.0 / 13.5 -> 11.0 /
  // 11.6 s, peak 240 -> 259 MB; the room's: 245 -> 143 s, the same peak). One call at a time
  // uses them; a call that finds them in use makes its own.
  struct NodeBuffers {
    std::vector<double> b, h;
  };
  class BorrowedBuffers;
  mutable std::mutex buffers_mutex_;
  mutable NodeBuffers buffers_;
};

// The element trees, their links and the operator.
class ElementHierarchy {
 public:
  const std::vector<Element>& elements() const { return elements_; }
  const std::vector<LinkedPair>& links() const { return links_; }
  const std::vector<ImageLink>& image_links() const { return image_links_; }
  // The mirror planes the image links go through (empty without them).
  const MirrorPlanes& mirrors() const { return mirrors_; }
  int num_roots() const { return num_roots_; }
  int num_leaves() const { return static_cast<int>(leaf_element_.size()); }
  // Leaf l (unknown l) as a patch: what a caller that indexes unknowns by patch reads (the
  // series' emission columns, patch tables). Its element's shape, not a copy of every leaf.
  const Patch& leaf(int l) const { return elements_[leaf_element_[l]].shape; }
  std::int32_t element_of_leaf(int leaf) const { return leaf_element_[leaf]; }
  std::shared_ptr<const HierarchicalOperator> op() const { return op_; }
  const HierarchyStats& stats() const { return stats_; }
  // The roots (the uniform mesh the trees stand on).
  const PatchSet& roots() const { return *roots_; }
  // With lobes (eq. H3): the root form factors of the last pass and the transfer computed after
  // the first, for the lobe check and the report (release_transfer frees their entries).
  const FormFactors& root_form_factors() const { return root_ff_; }
  // The last solve between passes on the final unknowns (each leaf as its element, or the
  // element it was split from, had it; each specular link as the same pair of roots carried
  // it): a Gauss-Seidel solve of the emission starts here (SolveOptions::start). Empty when no
  // pass solved. 24 bytes an unknown.
  const Field& solution_guess() const { return guess_; }
  const SpecularTransfer& root_transfer() const { return transfer_; }
  void release_transfer();

  // The leaf under parameters (u, v) of root patch `root` (Patch::point's parameters; a quad's
  // ray-caster parameters are first moved onto its bilinear map, which differs from Embree's
  // two triangles on a non-parallelogram).
  LeafPoint leaf_at(PatchId root, double u, double v) const;
  // The diffuse radiosity a hit reads as weights on the unknowns, appended to out: its leaf
  // (flat), or the leaf's corners interpolated at the hit (smooth), each corner the
  // exposed-area average of the leaves of the same object and orientation that touch it.
  void diffuse_weights(PatchId root, double u, double v, bool smooth,
                       std::vector<std::pair<std::int32_t, double>>& out) const;
  // The same for a point already located (leaf_at), which the final gather also asks its leaf's
  // size of: one descent a hit instead of two.
  void diffuse_weights(const LeafPoint& point, bool smooth,
                       std::vector<std::pair<std::int32_t, double>>& out) const;

  // What leaf_at descends through: per element its children, its unknown, its diameter and its
  // parameter corners 0, 1, 2. 64 bytes against an Element's 352, so that the descent of each
  // of the final gather's hits stays in cache (on the mirror cube the Element's first_child
  // missed it and leaf_at took 15 percent of the render).
  struct LookupNode {
    std::int32_t first_child = -1, leaf = -1;
    double diameter = 0.0;
    std::array<Vec2, 3> uv{};
  };
  static_assert(sizeof(LookupNode) == 64, "a lookup node is one cache line");

 private:
  friend class HierarchyBuilder;
  void build_corner_averages(const PatchSet& roots);
  void build_lookup(const PatchSet& roots);
  std::vector<Element> elements_;
  std::vector<LinkedPair> links_;
  std::vector<ImageLink> image_links_;
  MirrorPlanes mirrors_;
  std::vector<std::int32_t> leaf_element_;
  const PatchSet* roots_ = nullptr;
  int num_roots_ = 0;
  std::shared_ptr<HierarchicalOperator> op_;
  HierarchyStats stats_;
  FormFactors root_ff_;
  SpecularTransfer transfer_;
  Field guess_;
  // Smooth shading: entries of leaf corner 4 l + c are [corner_start_[4l+c],
  // corner_start_[4l+c+1]).
  std::vector<std::int64_t> corner_start_;
  std::vector<std::pair<std::int32_t, float>> corner_entries_;
  std::vector<LookupNode> lookup_;
  std::vector<char> skewed_;  // per root: a quad whose bilinear map is not Embree's (leaf_at)
  // Per quad root, its tree as a grid of 2^d x 2^d cells in its parameters, each the element
  // the descent reaches at depth d (d = 0: none): leaf_at starts there instead of at the root.
  std::vector<std::uint8_t> grid_depth_;
  std::vector<std::int64_t> grid_start_;
  std::vector<std::int32_t> grid_;
};

// Builds the trees on the uniform mesh `roots` (which the caster was built on, and which must
// outlive the hierarchy), links them and refines them pass by pass. With lobes (and
// options.specular_links), the specular transfer on the roots is computed after the first pass
// and the root links join the operator (eq. H3): the solves between passes carry them, and the
// oracle judges a link from a reflector by B_s + S_{root(s)->root(r)}.
ElementHierarchy build_hierarchy(const PatchSet& roots, const std::vector<Material>& materials,
                                 const RayCaster& caster, const HierarchyOptions& options = {});

// The form factors between the roots of a hierarchy that a specular transfer on the roots
// needs (section 12.6): the rows of the roots whose material has a lobe, each F_ij the sum of
// the etendues of the links between the two trees over A'_i (so a tree of one level gives the
// uniform mesh's), and A' of every root. Other rows are empty. No rays. The links are those
// `for_each_link` hands its visitor, one call a link: the builder's own while it refines, the
// hierarchy's links() once it is done.
using LinkVisitor = std::function<void(const LinkedPair&)>;
FormFactors root_form_factors(const ElementHierarchy& h, const std::vector<Material>& materials,
                              const std::function<void(const LinkVisitor&)>& for_each_link);

// The specular part of eq. H3 from the root form factors and the transfer computed on them
// (compute_specular_transfer on the roots): the active links, their rows, both couplings.
RootSpecular build_root_specular(const ElementHierarchy& h, const std::vector<Material>& materials,
                                 const FormFactors& roots, const SpecularTransfer& transfer);

// T over the hierarchy's leaves (unknown l = leaf l), then its specular links if it has them
// (unknown leaves + l, link l = S_{i->k} between roots), with TransportOperator's whole
// contract: apply on fields and blocks, Gauss-Seidel, flux weights (pi A'_l, tau_ik), a_max.
// Its layout holds the hierarchy, so that a gather of it reads leaves; link_unknown(i, k) takes
// root ids, as a ray hit names them.
TransportOperator hierarchical_transport(std::shared_ptr<const ElementHierarchy> h,
                                         const std::vector<Material>& materials);

}  // namespace polyrad
