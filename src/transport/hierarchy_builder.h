// The builder of an element hierarchy (hierarchy.h), internal to it: the links as the oracle
// measures and keeps them between passes, and the HierarchyBuilder whose passes grow the trees,
// link them and lay out the operator. Implemented in hierarchy.cpp (the trees and the passes),
// hierarchy_refine.cpp (the oracle and the links' form factors), hierarchy_images.cpp (the image
// links through planar mirrors, eq. H4) and hierarchy_make_operator.cpp (the operator's layout,
// link rows and energy guard).
// Not installed: the public interface is include/polyrad/transport/hierarchy.h.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "polyrad/transport/hierarchy.h"
#include "polyrad/util/sampling.h"
#include "polyrad/util/timer.h"

namespace polyrad {

// What the oracle's visibility rays found between the two elements of a link.
enum class LinkVisibility : std::uint8_t { kUntested, kVisible, kPartial, kHidden };

// A link while the hierarchy is built (LinkedPair, with what the oracle measured on it).
struct ElementLink {
  std::int32_t a = 0, b = 0;
  float m = 0.0f;
  // The oracle's unoccluded point form factors (eq. 5) from a's sample points to b (fa) and
  // from b's to a (fb): the corners pulled 1 percent toward the centre (on a corner that lies
  // in the other's plane the kernel jumps), then the centre; a triangle repeats its centre.
  std::array<float, kOraclePoints> fa{}, fb{};
  LinkVisibility visibility = LinkVisibility::kUntested;
  // A partly hidden pair's largest unoccluded point values (fa, fb are then weighed by each
  // point's visible fraction).
  float fmax_a = 0.0f, fmax_b = 0.0f;
  // An image link's mirror plane (b seen in it from a, a from b), -1 for a direct link.
  std::int32_t mirror = -1;
};

// A link as the builder holds it between passes: each side's point values as 8-bit fractions
// of a scale (the partly hidden pair's F_max, else the largest value), so 32 bytes where an
// ElementLink takes 64; the links are the build's largest array, held beside the operator
// through each solve between passes (14 MB on the mirror cube at tau 0.05). A value comes back
// within 0.2 percent of its side's scale: below the spread the oracle weighs (tau of the mean,
// eq. H1) at the tolerances the gathers use. make_operator fits the links' slopes to them too.
// 16-bit fractions held 12 bytes more a link for the same images (the mirror cube, cornell-box
// and cornell-glossy at tau 0.05 and 0.07: relative RMSE the same to four digits, links within
// 0.15 percent). At tight tolerances the coarser steps ask for some splits more (cornell-box: 1
// percent more links at tau 0.02, 4 at 0.005; codes of the square root, finer for small values
// and coarser near the scale, asked for 2 and 12), with lower peaks and the same image error.
struct KeptLink {
  std::int32_t a = 0, b = 0;
  float m = 0.0f;
  float scale_a = 0.0f, scale_b = 0.0f;
  LinkVisibility visibility = LinkVisibility::kUntested;
  std::array<std::uint8_t, kOraclePoints> qa{}, qb{};
  std::uint8_t plane = 0;  // an image link's mirror plane + 1 (kMaxMirrorPlanes), 0 direct

  std::int32_t mirror() const { return static_cast<std::int32_t>(plane) - 1; }
  static KeptLink keep(const ElementLink& l) {
    KeptLink k;
    k.a = l.a;
    k.b = l.b;
    k.m = l.m;
    k.visibility = l.visibility;
    k.plane = static_cast<std::uint8_t>(l.mirror + 1);
    const bool partial = l.visibility == LinkVisibility::kPartial;
    k.scale_a = scale_of(partial ? l.fmax_a : *std::max_element(l.fa.begin(), l.fa.end()));
    k.scale_b = scale_of(partial ? l.fmax_b : *std::max_element(l.fb.begin(), l.fb.end()));
    quantize(l.fa, k.scale_a, k.qa);
    quantize(l.fb, k.scale_b, k.qb);
    return k;
  }
  ElementLink expand() const {
    ElementLink l;
    l.a = a;
    l.b = b;
    l.m = m;
    l.visibility = visibility;
    l.mirror = mirror();
    const bool partial = visibility == LinkVisibility::kPartial;
    l.fmax_a = partial ? scale_a : 0.0f;
    l.fmax_b = partial ? scale_b : 0.0f;
    for (int k = 0; k < kOraclePoints; ++k) {
      l.fa[k] = static_cast<float>(qa[k] * (static_cast<double>(scale_a) / kFull));
      l.fb[k] = static_cast<float>(qb[k] * (static_cast<double>(scale_b) / kFull));
    }
    return l;
  }
  void swap_ends() {
    std::swap(a, b);
    std::swap(scale_a, scale_b);
    std::swap(qa, qb);
  }

 private:
  static constexpr double kFull = 255.0;
  // A side whose values are not finite keeps none (each value then reads 0).
  static float scale_of(float largest) { return std::isfinite(largest) ? largest : 0.0f; }
  static void quantize(const std::array<float, kOraclePoints>& f, float scale,
                       std::array<std::uint8_t, kOraclePoints>& q) {
    for (int k = 0; k < kOraclePoints; ++k) {
      const double x = scale > 0.0f && std::isfinite(f[k])
                           ? std::clamp(f[k] / static_cast<double>(scale), 0.0, 1.0)
                           : 0.0;
      q[k] = static_cast<std::uint8_t>(std::lround(x * kFull));
    }
  }
};
static_assert(sizeof(KeptLink) == 32, "a kept link is 32 bytes");

namespace hierarchy_detail {

// Helpers more than one of the builder's files reads.

inline double longest_edge(const Patch& p) {
  double e = 0.0;
  for (int c = 0; c < p.corners; ++c)
    e = std::max(e, (p.corner[(c + 1) % p.corners] - p.corner[c]).norm());
  return e;
}

// Whether a corner of p lies in front of the plane of `plane` (by more than eps).
inline bool any_corner_in_front(const Patch& p, const Patch& plane, double eps) {
  for (int c = 0; c < p.corners; ++c)
    if ((p.corner[c] - plane.centroid).dot(plane.normal) > eps) return true;
  return false;
}

// A convex polygon of at most 24 corners on the stack: an element has 4, a clip adds 1 a plane,
// and an image cut by a mirror's outline (at most 8 corners, hierarchy_images.cpp) at most 14.
struct SmallPolygon {
  std::array<Vec3, 24> v;
  int n = 0;
  SmallPolygon() = default;
  explicit SmallPolygon(const Patch& p) : n(p.corners) {
    for (int k = 0; k < p.corners; ++k) v[k] = p.corner[k];
  }
};

// The part of polygon p in front of the plane through `origin` with normal `normal`.
inline void clip_front(const SmallPolygon& p, const Vec3& origin, const Vec3& normal,
                       SmallPolygon& out) {
  out.n = 0;
  for (int k = 0; k < p.n; ++k) {
    const Vec3& a = p.v[k];
    const Vec3& b = p.v[(k + 1) % p.n];
    const double da = (a - origin).dot(normal), db = (b - origin).dot(normal);
    if (da >= 0.0) out.v[out.n++] = a;
    if ((da >= 0.0) != (db >= 0.0)) out.v[out.n++] = a + (da / (da - db)) * (b - a);
  }
}

// Eq. 5, unoccluded, from r's oracle points (see ElementLink) to the polygon s, of normal n_s
// through c_s, clipped to r's front.
void point_values(const Patch& r, const SmallPolygon& s, const Vec3& n_s, const Vec3& c_s,
                  double eps, std::array<float, kOraclePoints>& f);
// The oracle's point x of r (k < kOraclePoints).
inline Vec3 oracle_point(const Patch& r, int k) {
  return k < r.corners ? Vec3(r.corner[k] + 0.01 * (r.centroid - r.corner[k])) : r.centroid;
}

// Whether none of e lies inside other geometry (its exposed area is all of it).
inline bool wholly_exposed(const Element& e) { return e.exposed >= e.shape.area * (1.0 - 1e-9); }

// How far a linear function of the root parameters with these slopes falls below its value at
// e's centroid, at most over e: a linear function's least value on a polygon is at a corner.
inline double corner_drop(const Element& e, const Vec2& slope) {
  double drop = 0.0;
  for (int k = 0; k < e.shape.corners; ++k)
    drop = std::max(drop, -slope.dot(e.uv[k] - e.centroid_uv));
  return drop;
}

// The linear function of the root parameters that fits the point form factors f over element r
// in least squares: its value at r's centroid, its slopes, and the most it misses a point by.
struct LinearFit {
  double mean = 0.0;
  Vec2 slope = Vec2::Zero();
  double miss = 0.0;
};
// (Defined in hierarchy_refine.cpp, beside the oracle's sample points it fits.)
LinearFit fit_linear(const Element& r, const std::array<float, kOraclePoints>& f);

}  // namespace hierarchy_detail

// Builds the trees and links pass by pass (see the top of hierarchy.h).
class HierarchyBuilder {
 public:
  HierarchyBuilder(const PatchSet& roots, const std::vector<Material>& materials,
                   const RayCaster& caster, const HierarchyOptions& o, ElementHierarchy& h)
      : roots_(roots), materials_(materials), caster_(caster), o_(o), h_(h), el_(h.elements_) {}

  void run();

 private:
  enum Decision : std::int8_t { kNone, kLink, kSplitA, kSplitB };
  struct Candidate {
    std::int32_t a, b;
    float m = -1.0f;  // the pair form factor when known (a link judged again after its rays)
    // What rays found between the pair's ancestors: the parts of a wholly visible pair are
    // taken as wholly visible too (Hanrahan et al.'s inheritance), without casting again.
    LinkVisibility visibility = LinkVisibility::kUntested;
    std::int32_t mirror = -1;  // an image link's plane (ElementLink::mirror)
  };
  struct Outcome {
    Decision decision = kNone;
    ElementLink link;  // a, b, the point form factors and what the rays found
    bool probed = false;
    long long rays = 0;
  };
  // A link a later pass splits: the end to split, the other end, what rays found between them.
  struct Split {
    std::int32_t element, other;
    LinkVisibility visibility;
    std::int32_t mirror = -1;
  };
  // The candidates a decided split of pair c makes: each child of the split end with the other
  // end; for an element seen in a mirror by itself (c.a == c.b), each pair of its children once.
  void split_pair(const Candidate& c, std::int32_t split_end, LinkVisibility v,
                  std::vector<Candidate>& out) const;

  bool splittable(std::int32_t e) const {
    return 0.5 * hierarchy_detail::longest_edge(el_[e].shape) >=
           min_size_[el_[e].root] * (1.0 - 1e-9);
  }
  // dF of eq. H1 for receiver `r` of link l (r is l.a or l.b).
  double spread(const ElementLink& l, std::int32_t r) const;
  // Whether link l passes eq. H1 for receiver r (r is l.a or l.b); the criteria stand with its
  // definition (hierarchy_refine.cpp).
  bool accurate_for(const ElementLink& l, std::int32_t r) const;
  bool accurate(const ElementLink& l) const { return accurate_for(l, l.a) && accurate_for(l, l.b); }
  // Whether link_form_factors integrates the pair with open_link_rays shadow rays a point: below
  // the roots, where the oracle saw no shadow.
  bool open_rules(std::int32_t a, std::int32_t b, LinkVisibility v) const {
    return !(el_[a].parent < 0 && el_[b].parent < 0) &&
           (v == LinkVisibility::kVisible || v == LinkVisibility::kUntested);
  }
  // Which of a, b to split: the larger that may be split; -1 if neither.
  std::int32_t split_choice(std::int32_t a, std::int32_t b) const {
    const bool sa = splittable(a), sb = splittable(b);
    if (sa && (!sb || el_[a].shape.area >= el_[b].shape.area)) return a;
    return sb ? b : -1;
  }
  // Point form factors of a pair (false: the pair does not face).
  bool point_form_factors(std::int32_t a, std::int32_t b, ElementLink& l) const;
  // The same for b seen from a in mirror plane q and a from b (false: the images do not face).
  bool image_point_form_factors(std::int32_t a, std::int32_t b, std::int32_t q,
                                ElementLink& l) const;
  // The exact unoccluded form factor from point x (normal n) to the image of polygon s (of
  // normal n_s, in front of plane q) seen through the plane's patches.
  double image_point_form_factor(const Vec3& x, const Vec3& n,
                                 const hierarchy_detail::SmallPolygon& s, const Vec3& n_s,
                                 std::int32_t q) const;
  // The etendue over pi of an image link: A_x F_{x y'} on the direct links' outer rule over x
  // toward y's image (pair_outer_rule), each point's
  // exact form factor through the mirror times, unless the pair is wholly visible, the share of
  // its rays to y that nothing hides.
  double image_pair_form_factor(std::int32_t x, std::int32_t y, std::int32_t q, LinkVisibility v,
                                long long* rays) const;
  // Whether the segment from x on a to y on b is open (for an image link: through its mirror;
  // kOutside where the segment to y's image misses the mirror's patches, which the form factors
  // through them leave out exactly).
  enum class Path { kOpen, kBlocked, kOutside };
  Path path_between(const ElementLink& l, const Vec3& x, const Patch& pa, const Vec3& y,
                    const Patch& pb, long long* rays) const;
  // A point of element `to` seen from x (on element `from`) through link l's mirror, for the
  // unit-square sample u: uniform over the part of the mirror's outline where to's image shows
  // from x (so a visibility ray never misses a small mirror); false where none shows. For a
  // direct link, to.sample(u).
  bool target_through(const ElementLink& l, std::int32_t from, std::int32_t to, const Vec3& x,
                      const Vec2& u, Vec3* y) const;
  // What x (on element `from`) sees of element `to`'s image in link l's mirror, cut into
  // triangles once, so that many points can be drawn through it (target_through draws one).
  struct ImageView {
    std::array<std::array<Vec3, 3>, 48> tri;  // the pieces of the outline, fans of triangles
    std::array<double, 48> area{};
    int count = 0;
    double total = 0.0;        // their summed area: 0 where none shows
    Vec3 x, image_normal, on;  // the viewpoint; the plane of to's image, and a point of it
    const MirrorPlanes::Plane* plane = nullptr;
    // A point of `to`, uniform over the pieces for the unit-square sample u (false: none).
    bool draw(const Vec2& u, Vec3* y) const;
  };
  // The view of image link l from x; its total is 0 where nothing shows.
  void image_view(const ElementLink& l, std::int32_t from, std::int32_t to, const Vec3& x,
                  ImageView* view) const;
  // Whether point p of mirror plane q lies on its outline.
  bool on_outline(const Vec3& p, std::int32_t q) const;
  // The root of mirror plane q under its point p, -1 for none.
  std::int32_t plane_root_at(const Vec3& p, std::int32_t q) const;
  // The root of plane q that the path between the centroids of a and b crosses (the nearest
  // root of the plane where it crosses none).
  std::int32_t crossing_root(std::int32_t a, std::int32_t b, std::int32_t q) const;
  // Whether receiver r takes light along an image link (no lobe: one with a lobe takes it on
  // its specular links).
  bool takes_images(std::int32_t r) const { return !root_lobe_[el_[r].root]; }
  // Element e's exposure: its fraction A'_e / A_e, with its grid where it has one.
  PatchExposure exposure_of(std::int32_t e) const;
  // Casts the pair's visibility rays; a partly hidden pair's point values are weighed by their
  // visible fractions.
  LinkVisibility probe(ElementLink& l, long long* rays) const;
  // How many: visibility_rays for elements up to eight smallest elements long (a root, at the
  // default smallest size), and as many again for each part of a larger one, cut into n x n
  // parts so long (n its longest edge over eight smallest elements, rounded up, at most
  // kMaxProbeSide): 16 rays between two whole walls saw none of a block's shadow between them,
  // and a wholly visible verdict is final for the pair (its links keep it, its children inherit
  // it).
  int probe_rays(std::int32_t a, std::int32_t b) const;
  // The visible fractions that weigh the point values f of end `which` of link l (0: a's,
  // toward b; 1: b's, toward a), exposure_to the other end's.
  void weigh_by_visibility(const ElementLink& l, int which, const PatchExposure& exposure_to,
                           std::array<float, kOraclePoints>& f, long long* rays) const;
  Outcome judge(const Candidate& c) const;
  std::uint64_t pair_key(std::int32_t a, std::int32_t b) const;
  // The key of a link's random streams: pair_key, mixed with the plane of an image link.
  std::uint64_t link_key(std::int32_t a, std::int32_t b, std::int32_t mirror) const {
    const std::uint64_t k = pair_key(a, b);
    return mirror < 0 ? k : mix64(k ^ (0x6d6972726f72ull + static_cast<std::uint64_t>(mirror)));
  }
  void split(std::int32_t e);
  void split_all(std::vector<std::int32_t>& elements, HierarchyPass& pass);
  // Judges the candidates, splits where the oracle asks and judges the children, until each pair
  // is linked or dropped; the links go to pending_ (hierarchy_refine.cpp, with the steps below).
  void refine(std::vector<Candidate> candidates, HierarchyPass& pass);
  // Throws InputError when the links kept so far exceed o_.max_link_bytes.
  void require_link_memory() const;
  // The oracle's seconds since `start`, when the exposure stage stood at `exposure0`: what
  // split_all measured of exposure meanwhile is that stage's own.
  double oracle_seconds_since(const Stopwatch& start, double exposure0) const {
    return start.seconds() - (h_.stats_.exposure_seconds - exposure0);
  }
  using Decisions = std::vector<std::pair<Decision, LinkVisibility>>;  // per candidate
  Decisions judge_all(const std::vector<Candidate>& candidates, HierarchyPass& pass);
  void keep_links(const std::vector<Candidate>& candidates, std::int64_t first,
                  const std::vector<Outcome>& outcome, Decisions& decided);
  std::vector<Candidate> split_decided(const std::vector<Candidate>& candidates,
                                       const Decisions& decided, HierarchyPass& pass);
  void link_form_factors(HierarchyPass& pass);
  // The operator on the current links (eq. H2; hierarchy_make_operator.cpp, with the steps
  // below).
  void make_operator();
  // The trees' nodes in pre-order (node_element_, the trees' starts); returns element -> node.
  std::vector<std::int32_t> lay_out_trees(HierarchicalOperator& op);
  void sum_inner_exposed();
  void lay_out_nodes(HierarchicalOperator& op, const std::vector<std::int32_t>& node_of);
  // Per node: the box (u0, v0, u1, v1) of its leaves' centroids in the root's parameters, about
  // the node's own centroid.
  using LeafBoxes = std::vector<std::array<double, 4>>;
  // The direct links' rows (images false) or the image links' (op.images_, with their planes).
  void fill_link_rows(HierarchicalOperator& op, const std::vector<std::int32_t>& node_of,
                      const LeafBoxes& boxes, bool images) const;
  Vec2 slope_of(std::int32_t r, const std::array<float, kOraclePoints>& points, LinkVisibility v,
                double mean) const;
  LeafBoxes box_leaf_centroids(const HierarchicalOperator& op) const;
  // How far the linear function of `slope` falls below its value at a node's centroid (element
  // r) at most, over `box`, its leaves' centroids' box, or over r, the smaller.
  double leaf_drop(std::int32_t r, const std::array<double, 4>& box, const Vec2& slope) const;
  struct LinkEntries {
    std::array<float, 5> a, b;  // in a's row and in b's: F, the receiver's slopes, c
  };
  LinkEntries link_entries(const ElementLink& l, const std::vector<std::int32_t>& node_of,
                           const LeafBoxes& boxes) const;
  void energy_guard(HierarchicalOperator& op);
  void guard_trees(HierarchicalOperator& op, const std::vector<double>& sums, double a_max) const;
  // With lobes: the root form factors of the current links, the transfer (once, after the
  // first pass) and the operator's specular part (eq. H3).
  void attach_specular();
  // The links as the hierarchy keeps them (LinkedPair), from links_, which is then freed: once,
  // when no later pass will judge them again. Before that the hierarchy holds no copy of them
  // (on the mirror cube, 5 MB at the build's peak).
  void publish_links();
  // run's steps (hierarchy.cpp).
  void make_roots();
  void first_radiosities();
  void judge_albedos();
  void first_pass();
  std::vector<Candidate> facing_root_pairs();
  // The image links' candidates of pass 0: pairs of roots that see each other in a mirror plane
  // (hierarchy_images.cpp).
  void find_mirror_planes();
  void outline_mirror_planes();
  std::vector<Candidate> mirrored_root_pairs();
  void bury_unlinked_roots();
  // Pass p >= 1; false where the last solve left no link to judge again (the passes end).
  bool later_pass(int p);
  void judge_links_again(std::vector<Candidate>& again, std::vector<Split>& split_links);
  void close_pass(HierarchyPass& pass, int p);
  // The solve between passes (Gauss-Seidel on the hierarchy), and what the oracle reads of it.
  int solve(HierarchyPass& pass);
  // The last solve's values on the current unknowns (the emission before the first solve).
  Field last_solution() const;
  void remember_specular(const Field& u);
  void pull_radiosity(const Field& u);
  void measure_b_ref(const Field& u, const Field& e, const std::vector<double>& w);
  // S_{i->k} of the last solve (0 where there is no such link).
  Eigen::Array3d specular_toward(PatchId i, PatchId k) const {
    const auto first = seen_links_.begin() + seen_start_[i];
    const auto last = seen_links_.begin() + seen_start_[i + 1];
    const auto it =
        std::lower_bound(first, last, k, [](const Link& x, PatchId key) { return x.to < key; });
    return it != last && it->to == k ? seen_s_[it - seen_links_.begin()]
                                     : Eigen::Array3d::Zero().eval();
  }

  const PatchSet& roots_;
  const std::vector<Material>& materials_;
  const RayCaster& caster_;
  const HierarchyOptions& o_;
  ElementHierarchy& h_;
  std::vector<Element>& el_;
  std::vector<double> min_size_;         // per root
  std::vector<Eigen::Array3d> rho_, b_;  // per element: reflectance, current radiosity
  // Links in chunks, each as one batch of refine judged them, never one vector regrown: on the
  // mirror cube a regrown copy of the links beside the old one was the build's peak.
  using LinkChunks = std::vector<std::vector<KeptLink>>;
  LinkChunks links_;    // the links so far
  LinkChunks pending_;  // judged to link, form factor still to compute
  std::int64_t image_link_count() const {
    auto n = static_cast<std::int64_t>(h_.image_links_.size());
    for (const auto& chunk : links_)
      for (const auto& l : chunk) n += l.mirror() >= 0 ? 1 : 0;
    return n;
  }
  std::int64_t link_count() const {
    // Before publish_links the hierarchy holds none of them, after it the builder none.
    auto n = static_cast<std::int64_t>(h_.links_.size() + h_.image_links_.size());
    for (const auto& chunk : links_) n += static_cast<std::int64_t>(chunk.size());
    return n;
  }
  // Exposure grids (exposure.h): the roots' map, then one per batch of children measured; per
  // element, its map and index there ({-1, -1}: none, as for the children of a wholly exposed
  // or buried parent).
  std::vector<ExposureMap> exposure_maps_;
  std::vector<std::array<std::int32_t, 2>> exposure_at_;
  std::vector<std::int32_t> node_element_;  // the operator's node -> element
  double b_ref_ = 0.0;
  bool lobes_ = false;  // some root has a lobe and the specular links are on
  std::vector<char> root_lobe_;  // per root: its material has a lobe (and lobes_)
  // Per mirror plane: its patches and their roots; and its outline, the convex polygons its
  // patches cover (one where they tile a convex polygon, the common case, else the patches).
  std::vector<std::vector<hierarchy_detail::SmallPolygon>> plane_patches_, plane_outline_;
  std::vector<std::vector<std::int32_t>> plane_roots_;
  bool transfer_done_ = false;
  // The specular links of the last solve and their values, for the oracle (specular_toward).
  std::vector<Link> seen_links_;
  std::vector<std::int64_t> seen_start_;
  std::vector<Eigen::Array3d> seen_s_;
  // Per root, as the oracle judges a receiver: its albedo d + s (d alone without lobes), and the
  // flux-weighted mean S of its links in the last solve.
  std::vector<Eigen::Array3d> judged_rho_, mean_s_;
  // Rays from each oracle point of a partly hidden pair to the other element (its visible
  // fraction there).
  static constexpr int kPointRays = 4;
  // The most parts a side a probe casts visibility_rays for (probe_rays): 16 times the rays.
  static constexpr int kMaxProbeSide = 4;
  // The darkest source and receiver, as a share of the mean reflected radiosity B_ref, that the
  // oracle judges by their own radiosity: a leaf's error is bounded by about
  // tau (B_reflected + kDarkest rho B_ref), relative where it is not darker than that.
  static constexpr double kDarkest = 0.25;
  // A visible link that carries this share of the tolerance on its receiver's radiosity is not
  // worth splitting, however large its miss is against that little light (a floor far from a
  // block sees its faces at grazing angles).
  static constexpr double kNegligible = 0.1;
};

}  // namespace polyrad
