// Element trees and the passes that link them (hierarchy.h, with the builder of
// hierarchy_builder.h). Equation numbers refer to papers/glossy-radiosity.md (H1 the oracle, H2
// the operator, H3 the specular links, section 12).
#include "polyrad/transport/hierarchy.h"

#include <algorithm>
#include <cmath>
#include <iterator>

#include "hierarchy_builder.h"
#include "polyrad/util/error.h"
#include "polyrad/util/sampling.h"
#include "polyrad/util/timer.h"

namespace polyrad {

namespace {

// A child's shape from its corners, as the mesher makes a patch (Newell normal, area centroid);
// the bend stays the root's, by which rays from any of its points are lifted (ray_caster.h).
Patch child_shape(const Patch& root, const std::array<Vec3, 4>& corner, int corners) {
  Patch p = root;
  p.corners = corners;
  p.corner = corner;
  if (corners == 3) p.corner[3] = p.corner[2];
  Vec3 n = Vec3::Zero();
  for (int a = 0; a < corners; ++a) n += p.corner[a].cross(p.corner[(a + 1) % corners]);
  p.area = 0.5 * n.norm();
  p.normal = n.normalized();
  const Vec3 c012 = (p.corner[0] + p.corner[1] + p.corner[2]) / 3.0;
  if (corners == 3) {
    p.centroid = c012;
  } else {
    const double a012 = 0.5 * (p.corner[1] - p.corner[0]).cross(p.corner[2] - p.corner[0]).norm();
    const Vec3 c023 = (p.corner[0] + p.corner[2] + p.corner[3]) / 3.0;
    const double a023 = 0.5 * (p.corner[2] - p.corner[0]).cross(p.corner[3] - p.corner[0]).norm();
    p.centroid = (a012 * c012 + a023 * c023) / (a012 + a023);
  }
  p.vertex_id = {0, 0, 0, 0};
  return p;
}

// The area centroid of an element in its root's parameters: exact on a 2 x 2 Gauss rule, as a
// planar quad's area density is linear in its parameters (a triangle's is constant).
Vec2 area_centroid_uv(const Patch& root, const std::array<Vec2, 4>& uv) {
  if (root.is_triangle()) return (uv[0] + uv[1] + uv[2]) / 3.0;
  const GaussRule& g = gauss_legendre(2);
  Vec2 sum = Vec2::Zero();
  double weight = 0.0;
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) {
      const Vec2 q = uv[0] + g.node[a] * (uv[1] - uv[0]) + g.node[b] * (uv[3] - uv[0]);
      Vec3 du, dv;
      root.tangents(q.x(), q.y(), &du, &dv);
      const double w = g.weight[a] * g.weight[b] * du.cross(dv).norm();
      sum += w * q;
      weight += w;
    }
  return weight > 0.0 ? Vec2(sum / weight) : Vec2((uv[0] + uv[2]) / 2.0);
}

}  // namespace

using hierarchy_detail::any_corner_in_front;
using hierarchy_detail::longest_edge;

void HierarchyBuilder::split(std::int32_t e) {
  if (el_[e].first_child >= 0) return;
  const Element parent = el_[e];  // a copy: el_ grows below
  const Patch& root = roots_[parent.root];
  const auto first = static_cast<std::int32_t>(el_.size());
  el_[e].first_child = first;
  // Grown by a quarter, not doubled: the slack sits beside the operator in the solves between
  // passes (elements are 352 bytes), and a copy of 20,000 is quick.
  if (el_.size() + 4 > el_.capacity()) {
    const std::size_t grown = el_.capacity() + el_.capacity() / 4 + 4;
    el_.reserve(grown);
    rho_.reserve(grown);
    b_.reserve(grown);
  }
  std::array<std::array<Vec2, 4>, 4> uvs;
  if (!root.is_triangle()) {
    const Vec2 lo = parent.uv[0], hi = parent.uv[2], mid = 0.5 * (lo + hi);
    for (int c = 0; c < 4; ++c) {
      const int a = c % 2, b = c / 2;  // child c = a + 2 b: a the u half, b the v half
      const double u0 = a ? mid.x() : lo.x(), u1 = a ? hi.x() : mid.x();
      const double v0 = b ? mid.y() : lo.y(), v1 = b ? hi.y() : mid.y();
      uvs[c] = {Vec2(u0, v0), Vec2(u1, v0), Vec2(u1, v1), Vec2(u0, v1)};
    }
  } else {
    const Vec2 &p0 = parent.uv[0], &p1 = parent.uv[1], &p2 = parent.uv[2];
    const Vec2 m01 = 0.5 * (p0 + p1), m12 = 0.5 * (p1 + p2), m20 = 0.5 * (p2 + p0);
    uvs[0] = {p0, m01, m20, m20};
    uvs[1] = {m01, p1, m12, m12};
    uvs[2] = {m20, m12, p2, p2};
    uvs[3] = {m12, m20, m01, m01};  // the middle one, counter-clockwise as its parent
  }
  for (int c = 0; c < 4; ++c) {
    Element child;
    child.root = parent.root;
    child.parent = e;
    child.level = parent.level + 1;
    child.uv = uvs[c];
    std::array<Vec3, 4> corner;
    for (int k = 0; k < 4; ++k) corner[k] = root.point(uvs[c][k].x(), uvs[c][k].y());
    child.shape = child_shape(root, corner, root.corners);
    child.centroid_uv = area_centroid_uv(root, child.uv);
    child.key = mix64(parent.key * 4 + static_cast<std::uint64_t>(c) + 1);
    // Exposure: a wholly exposed or wholly buried parent passes it on; a partly buried one's
    // children are measured again (below, in split_all).
    const double fraction = parent.shape.area > 0.0 ? parent.exposed / parent.shape.area : 0.0;
    child.exposed = fraction >= 1.0 - 1e-12 ? child.shape.area : (fraction <= 0.0 ? 0.0 : -1.0);
    el_.push_back(child);
    rho_.push_back(rho_[e]);
    b_.push_back(b_[e]);
  }
}

void HierarchyBuilder::split_all(std::vector<std::int32_t>& elements, HierarchyPass& pass) {
  std::sort(elements.begin(), elements.end());
  elements.erase(std::unique(elements.begin(), elements.end()), elements.end());
  pass.splits += static_cast<long long>(elements.size());
  const auto before = static_cast<std::int32_t>(el_.size());
  for (std::int32_t e : elements) split(e);
  exposure_at_.resize(el_.size(), {-1, -1});  // the new children: no grid unless measured below
  // Children of partly buried parents: their exposed area on 8 x 8 points, 16 x 16 where the
  // buried boundary crosses them (the roots had 4 x 4 and 32 x 32).
  PatchSet measure;
  std::vector<std::int32_t> which;
  for (auto c = before; c < static_cast<std::int32_t>(el_.size()); ++c)
    if (el_[c].exposed < 0.0) {
      measure.patches.push_back(el_[c].shape);
      which.push_back(c);
    }
  if (!which.empty()) {
    const Stopwatch t0;
    const auto map = static_cast<std::int32_t>(exposure_maps_.size());
    exposure_maps_.emplace_back(measure, caster_, 8, 16);
    for (size_t k = 0; k < which.size(); ++k) {
      el_[which[k]].exposed = exposure_maps_.back().area(static_cast<PatchId>(k));
      exposure_at_[which[k]] = {map, static_cast<std::int32_t>(k)};
    }
    h_.stats_.exposure_seconds += t0.seconds();
  }
}

int HierarchyBuilder::solve(HierarchyPass& pass) {
  const Stopwatch t0;
  const HierarchicalOperator& op = *h_.op_;
  const auto leaves = static_cast<Eigen::Index>(h_.num_leaves());
  const RootSpecular* sp = op.specular();
  const Eigen::Index size = op.size();
  Field e = Field::Zero(size, 3);
  std::vector<double> w(size);  // flux weights over pi: A'_l, then tau_ik / pi
  for (Eigen::Index l = 0; l < leaves; ++l) {
    e.row(l) = h_.leaf(static_cast<int>(l)).emission.matrix().transpose();
    w[l] = el_[h_.leaf_element_[l]].exposed;
  }
  for (Eigen::Index l = leaves; l < size; ++l) w[l] = sp->flux_weight[l - leaves] / kPi;
  auto norm = [&](const auto& f) {  // a field or an expression (no field per sweep)
    double s = 0.0;
    for (Eigen::Index l = 0; l < size; ++l) s += w[l] * f.row(l).cwiseAbs().sum();
    return s;
  };
  const double norm_e = norm(e);
  // From the last solve: the same fixed point in fewer sweeps.
  Field u = last_solution(), previous;
  int sweeps = 0;
  for (; sweeps < 200 && norm_e > 0.0; ++sweeps) {
    previous = u;
    op.gauss_seidel_sweep(e, u);
    if (!u.allFinite()) throw NumericalError("the hierarchy's solve between passes diverged");
    if (norm(u - previous) < o_.pass_tolerance * norm_e) {
      ++sweeps;
      break;
    }
  }
  remember_specular(u);
  pull_radiosity(u);
  measure_b_ref(u, e, w);
  pass.sweeps = sweeps;
  pass.solve_seconds += t0.seconds();
  return sweeps;
}

// Each leaf as its element was, a new one as its parent (split copies b_), each link as the
// same pair of roots carried.
Field HierarchyBuilder::last_solution() const {
  const auto leaves = static_cast<Eigen::Index>(h_.num_leaves());
  const RootSpecular* sp = h_.op_->specular();
  const Eigen::Index size = h_.op_->size();
  Field u(size, 3);
  for (Eigen::Index l = 0; l < leaves; ++l) u.row(l) = b_[h_.leaf_element_[l]].matrix().transpose();
  for (Eigen::Index l = leaves; l < size; ++l) {
    const Link& link = sp->links[l - leaves];
    u.row(l) = specular_toward(link.from, link.to).matrix().transpose();
  }
  return u;
}

// The specular links' values, for the oracle's sources in reflectors' trees.
void HierarchyBuilder::remember_specular(const Field& u) {
  const auto leaves = static_cast<Eigen::Index>(h_.num_leaves());
  const RootSpecular* sp = h_.op_->specular();
  const Eigen::Index size = h_.op_->size();
  seen_links_.clear();
  seen_s_.clear();
  seen_start_.assign(roots_.size() + 1, 0);
  if (sp) {
    seen_links_ = sp->links;
    seen_start_ = sp->link_start;
    for (Eigen::Index l = leaves; l < size; ++l) seen_s_.push_back(u.row(l).transpose().array());
    for (std::size_t i = 0; i < roots_.size(); ++i) {
      Eigen::Array3d sum = Eigen::Array3d::Zero();
      double weight = 0.0;
      for (auto l = seen_start_[i]; l < seen_start_[i + 1]; ++l) {
        sum += sp->flux_weight[l] * seen_s_[l];
        weight += sp->flux_weight[l];
      }
      mean_s_[i] = weight > 0.0 ? Eigen::Array3d(sum / weight) : Eigen::Array3d::Zero();
    }
  }
}

// Radiosity of every element: its leaves' area average (the pull, without the guard).
void HierarchyBuilder::pull_radiosity(const Field& u) {
  const auto leaves = static_cast<Eigen::Index>(h_.num_leaves());
  for (Eigen::Index l = 0; l < leaves; ++l) b_[h_.leaf_element_[l]] = u.row(l).transpose().array();
  for (auto k = static_cast<std::int64_t>(node_element_.size()) - 1; k >= 0; --k) {
    const Element& x = el_[node_element_[k]];
    if (x.first_child < 0) continue;
    Eigen::Array3d sum = Eigen::Array3d::Zero();
    for (int c = 0; c < 4; ++c) {
      const Element& child = el_[x.first_child + c];
      if (x.exposed > 0.0) sum += (child.exposed / x.exposed) * b_[x.first_child + c];
    }
    b_[node_element_[k]] = sum;
  }
}

// From now on B_ref is the solution's own mean reflected radiosity (luminance, by exposed
// area): the first pass's estimate assumes a closed scene, and an open one loses light.
void HierarchyBuilder::measure_b_ref(const Field& u, const Field& e, const std::vector<double>& w) {
  const auto leaves = static_cast<Eigen::Index>(h_.num_leaves());
  double area = 0.0, sum = 0.0;
  for (Eigen::Index l = 0; l < leaves; ++l) {
    area += w[l];
    sum += w[l] * luminance((u.row(l) - e.row(l)).transpose().array());
  }
  if (area > 0.0 && sum > 0.0) b_ref_ = h_.stats_.b_ref = sum / area;
}

void HierarchyBuilder::run() {
  const Stopwatch t_start;
  h_.num_roots_ = static_cast<std::int32_t>(roots_.size());
  h_.roots_ = &roots_;
  make_roots();
  first_radiosities();
  judge_albedos();
  find_mirror_planes();
  first_pass();
  for (int p = 1; p <= o_.passes; ++p)
    if (!later_pass(p)) break;
  if (!links_.empty()) publish_links();  // the passes ended early
  const bool solved = std::any_of(h_.stats_.passes.begin(), h_.stats_.passes.end(),
                                  [](const HierarchyPass& p) { return p.sweeps > 0; });
  if (solved) h_.guess_ = last_solution();
  el_.shrink_to_fit();  // the last growth's slack (split grows the arrays by a quarter)
  const Stopwatch t_lookup;
  h_.build_corner_averages(roots_);
  h_.build_lookup(roots_);
  h_.stats_.lookup_seconds = t_lookup.seconds();
  h_.stats_.seconds = t_start.seconds();
}

// The roots, with the uniform mesh's exposed areas (form_factors.h), and the smallest size
// their elements may be split to. A root's burial is first tested on points no further apart
// than two of its smallest elements (4 x 4 at the default eighth of a root), up to the refined
// grid's 32 x 32: a child inherits a wholly exposed parent's exposure untested, so a buried
// region the roots' test missed would stay exposed at every level. (A lamp flush under a
// whole-ceiling root fell between the 4 x 4 points: its leaves took the light the ring around the
// lamp was owed.)
void HierarchyBuilder::make_roots() {
  const auto r = static_cast<std::int32_t>(roots_.size());
  HierarchyStats& st = h_.stats_;
  min_size_.resize(r);
  std::vector<int> points(r);
  for (std::int32_t p = 0; p < r; ++p) {
    const double edge = longest_edge(roots_[p]);
    min_size_[p] = o_.smallest_element(edge);
    const double spaced = edge > 0.0 ? std::ceil(edge / (2.0 * min_size_[p]) - 1e-9) : 0.0;
    const auto refined = static_cast<double>(o_.form_factors.exposure_refined);
    points[p] =
        std::max(o_.form_factors.exposure_points, static_cast<int>(std::min(spaced, refined)));
  }
  const Stopwatch t0;
  exposure_maps_.emplace_back(roots_, caster_, points, o_.form_factors.exposure_refined);
  exposure_at_.resize(r);
  for (std::int32_t p = 0; p < r; ++p) exposure_at_[p] = {0, p};
  st.exposure_seconds += t0.seconds();
  el_.resize(r);
  for (std::int32_t p = 0; p < r; ++p) {
    Element& e = el_[p];
    e.shape = roots_[p];
    e.root = p;
    e.key = static_cast<std::uint64_t>(p);
    e.exposed = exposure_maps_[0].area(p);
    e.uv = roots_[p].is_triangle()
               ? std::array<Vec2, 4>{Vec2(0, 0), Vec2(1, 0), Vec2(0, 1), Vec2(0, 1)}
               : std::array<Vec2, 4>{Vec2(0, 0), Vec2(1, 0), Vec2(1, 1), Vec2(0, 1)};
    e.centroid_uv = area_centroid_uv(roots_[p], e.uv);
  }
  st.link_tolerance = o_.tolerance();
  st.min_element_size = o_.min_element_size > 0.0 ? o_.min_element_size : 0.0;
}

// Each root's reflectance and radiosity as the first pass knows them, and B_ref: the mean
// radiosity of a scene whose surfaces all had the mean reflectance.
void HierarchyBuilder::first_radiosities() {
  const auto r = static_cast<std::int32_t>(roots_.size());
  HierarchyStats& st = h_.stats_;
  double area = 0.0, emitted = 0.0, reflected = 0.0;
  rho_.resize(r);
  b_.resize(r);
  for (std::int32_t p = 0; p < r; ++p) {
    const Patch& q = roots_[p];
    rho_[p] = materials_[q.material].diffuse;
    b_[p] = q.emission;  // the first pass knows only the emission
    area += q.area;
    emitted += q.area * luminance(q.emission);
    reflected += q.area * luminance(rho_[p]);
  }
  const double mean_rho = area > 0.0 ? std::min(reflected / area, 0.99) : 0.0;
  st.b_ref = area > 0.0 ? emitted / area / (1.0 - mean_rho) : 0.0;
  b_ref_ = st.b_ref_estimate = st.b_ref;
  seen_start_.assign(r + 1, 0);  // no specular light known before the first solve
}

// Whether a root has a lobe that specular links follow (lobes_); per root, the albedo the oracle
// judges it by as a receiver, and no mean S of its links yet.
void HierarchyBuilder::judge_albedos() {
  const auto r = static_cast<std::int32_t>(roots_.size());
  for (std::int32_t p = 0; p < r && o_.specular_links; ++p)
    lobes_ = lobes_ || materials_[roots_[p].material].has_lobe();
  judged_rho_.resize(r);
  mean_s_.assign(r, Eigen::Array3d::Zero());
  for (std::int32_t p = 0; p < r; ++p) {
    const Material& m = materials_[roots_[p].material];
    judged_rho_[p] = lobes_ && m.has_lobe() ? Eigen::Array3d(m.diffuse + m.specular) : m.diffuse;
  }
}

// Pass 0: every facing pair of roots (as the uniform mesh's pair loop), judged with B = E.
void HierarchyBuilder::first_pass() {
  HierarchyPass pass;
  const Stopwatch t0;
  std::vector<Candidate> candidates = facing_root_pairs();
  std::vector<Candidate> mirrored = mirrored_root_pairs();
  candidates.insert(candidates.end(), mirrored.begin(), mirrored.end());
  pass.oracle_seconds += t0.seconds();  // finding the candidates is the oracle's too
  refine(std::move(candidates), pass);
  link_form_factors(pass);
  bury_unlinked_roots();
  close_pass(pass, 0);
}

// The candidates of pass 0: the pairs of exposed roots that face each other (with
// root_pairs_facing, which counts the buried ones too).
std::vector<HierarchyBuilder::Candidate> HierarchyBuilder::facing_root_pairs() {
  const auto r = static_cast<std::int32_t>(roots_.size());
  std::vector<Candidate> candidates;
  std::vector<std::vector<Candidate>> rows(r);
  long long facing = 0;
#pragma omp parallel for schedule(dynamic, 16) reduction(+ : facing)
  for (std::int32_t i = 0; i < r; ++i) {
    const Patch& pi = roots_[i];
    for (std::int32_t j = i + 1; j < r; ++j) {
      const Patch& pj = roots_[j];
      const double eps = 1e-9 * std::max(pi.diameter(), pj.diameter());
      if (!any_corner_in_front(pj, pi, eps) || !any_corner_in_front(pi, pj, eps)) continue;
      ++facing;
      if (el_[i].exposed > 0.0 && el_[j].exposed > 0.0) rows[i].push_back({i, j});
    }
  }
  h_.stats_.root_pairs_facing = facing;
  for (auto& row : rows) candidates.insert(candidates.end(), row.begin(), row.end());
  return candidates;
}

// A root that exchanges light with nothing has no exposed area (as in the uniform mesh: a
// block's face pressed flat on the floor, whose probes cannot tell it is buried).
void HierarchyBuilder::bury_unlinked_roots() {
  std::vector<char> linked(roots_.size(), 0);
  for (const auto& chunk : links_)
    for (const auto& l : chunk) {
      linked[el_[l.a].root] = 1;
      linked[el_[l.b].root] = 1;
    }
  for (auto& e : el_)
    if (!linked[e.root]) e.exposed = 0.0;
}

// Later passes: with the radiosities of the last solve, the links that have become too coarse
// are judged again: first casting their rays if the first pass linked them without, else
// splitting the larger end.
bool HierarchyBuilder::later_pass(int p) {
  HierarchyPass next;
  std::vector<Candidate> again;
  std::vector<Split> split_links;
  const Stopwatch t0;
  const double exposure0 = h_.stats_.exposure_seconds;
  judge_links_again(again, split_links);
  if (again.empty() && split_links.empty()) {  // nothing to refine: the judging is the last pass's
    if (!h_.stats_.passes.empty())
      h_.stats_.passes.back().oracle_seconds += oracle_seconds_since(t0, exposure0);
    return false;
  }
  std::vector<std::int32_t> to_split;
  for (const auto& sl : split_links) to_split.push_back(sl.element);
  split_all(to_split, next);
  next.oracle_seconds += oracle_seconds_since(t0, exposure0);  // refine adds its own
  for (const auto& sl : split_links)
    split_pair({sl.element, sl.other, -1.0f, sl.visibility, sl.mirror}, sl.element, sl.visibility,
               again);
  refine(std::move(again), next);
  link_form_factors(next);
  close_pass(next, p);
  return true;
}

// The links the last solve finds too coarse (eq. H1) leave links_: one linked without rays
// becomes a candidate again, one with rays is split at its larger end where either may split.
void HierarchyBuilder::judge_links_again(std::vector<Candidate>& again,
                                         std::vector<Split>& split_links) {
  // Per link of a chunk: kept, judged again (kAgain), or the end to split; judged on both
  // threads, then applied in the chunk's order, so that the candidates and the kept links come
  // out as one thread makes them.
  constexpr std::int32_t kKeep = -2, kAgain = -1;
  std::vector<std::int32_t> verdict;
  for (auto& chunk : links_) {  // the links kept, compacted in place (no copy of them all)
    const auto size = static_cast<std::int64_t>(chunk.size());
    verdict.resize(chunk.size());
#pragma omp parallel for schedule(dynamic, 256)
    for (std::int64_t k = 0; k < size; ++k) {
      const ElementLink l = chunk[k].expand();
      std::int32_t v = kKeep;
      if (l.visibility == LinkVisibility::kUntested) {
        if (!accurate(l)) v = kAgain;
      } else if (!accurate(l)) {
        const std::int32_t s = split_choice(l.a, l.b);
        v = s < 0 ? kKeep : s;
      }
      verdict[k] = v;
    }
    std::size_t kept = 0;
    for (std::size_t k = 0; k < chunk.size(); ++k) {
      const KeptLink& l = chunk[k];
      const std::int32_t v = verdict[k];
      if (v == kKeep)
        chunk[kept++] = l;
      else if (v == kAgain)
        again.push_back({l.a, l.b, l.m, LinkVisibility::kUntested, l.mirror()});
      else
        split_links.push_back({v, v == l.a ? l.b : l.a, l.visibility, l.mirror()});
    }
    chunk.resize(kept);
    chunk.shrink_to_fit();  // one chunk's copy at a time; the slack was 5 MB on the mirror cube
  }
  std::erase_if(links_, [](const auto& chunk) { return chunk.empty(); });
}

// The end of pass p (0 the first): its operator and counts, then a solve for the next pass to
// judge by, or after the last the links published.
void HierarchyBuilder::close_pass(HierarchyPass& pass, int p) {
  const Stopwatch t0;
  make_operator();
  pass.operator_seconds = t0.seconds();
  if (p == o_.passes) publish_links();
  attach_specular();
  pass.links = link_count();
  h_.stats_.image_links = image_link_count();
  pass.elements = static_cast<long long>(el_.size());
  pass.leaves = h_.num_leaves();
  if (p < o_.passes) solve(pass);
  h_.stats_.passes.push_back(pass);
}

void HierarchyBuilder::publish_links() {
  std::vector<LinkedPair> pairs;
  pairs.reserve(static_cast<std::size_t>(link_count()));
  // What the oracle measured goes chunk by chunk as it is copied, before the last specular part
  // is built: the pairs' reserved pages become resident only as they are filled, so the kept
  // links (19 MB on the mirror cube) shrink as they grow (5 MB). Freed only at the end, both
  // beside the operator were the build's peak (72.3 MiB against 68.8 at make_operator).
  std::vector<ImageLink> images;
  for (auto& chunk : links_) {
    for (const KeptLink& l : chunk) {
      if (l.mirror() >= 0)
        images.push_back({{l.a, l.b, l.m}, l.mirror()});
      else
        pairs.push_back({l.a, l.b, l.m});
    }
    std::vector<KeptLink>().swap(chunk);
  }
  h_.links_.swap(pairs);
  h_.image_links_.swap(images);
  LinkChunks().swap(links_);
}

void HierarchyBuilder::attach_specular() {
  if (!lobes_) return;
  HierarchyStats& st = h_.stats_;
  Stopwatch watch;
  h_.root_ff_ = root_form_factors(h_, materials_, [&](const LinkVisitor& visit) {
    for (const LinkedPair& l : h_.links_) visit(l);  // published (then links_ is empty)
    for (const auto& chunk : links_)
      for (const KeptLink& l : chunk)
        if (l.mirror() < 0) visit({l.a, l.b, l.m});
  });
  st.root_form_factor_seconds += watch.lap();
  st.root_form_factors = h_.root_ff_.f.nnz();
  // The transfer once, on the first pass's root form factors: later passes split links but
  // keep their pairs of roots, and R_jik is a fraction (each row at most 1) whatever form
  // factors later normalise the flux weights by.
  if (!transfer_done_) {
    h_.transfer_ = compute_specular_transfer(roots_, materials_, h_.root_ff_, caster_, o_.specular);
    transfer_done_ = true;
    st.transfer_seconds += watch.lap();
    st.transfer_entries = h_.transfer_.entries();
  }
  RootSpecular sp = build_root_specular(h_, materials_, h_.root_ff_, h_.transfer_);
  st.specular_links = sp.num_links();
  st.specular_row_entries = sp.rows.nnz();
  h_.op_->specular_ = std::make_shared<const RootSpecular>(std::move(sp));
  st.specular_link_seconds += watch.lap();
}

void ElementHierarchy::release_transfer() {
  root_ff_ = FormFactors{};
  const SpecularStats stats = transfer_.stats;
  transfer_ = SpecularTransfer{};
  transfer_.stats = stats;
}

ElementHierarchy build_hierarchy(const PatchSet& roots, const std::vector<Material>& materials,
                                 const RayCaster& caster, const HierarchyOptions& options) {
  ElementHierarchy h;
  HierarchyBuilder(roots, materials, caster, options, h).run();
  return h;
}

TransportOperator hierarchical_transport(std::shared_ptr<const ElementHierarchy> hierarchy,
                                         const std::vector<Material>& materials) {
  const ElementHierarchy& h = *hierarchy;
  TransportOperator t;
  t.hierarchy_ = h.op();
  t.layout_.hierarchy = hierarchy;
  const auto leaves = h.num_leaves();
  t.layout_.num_patches = leaves;
  t.layout_.flux_weight.resize(leaves);
  t.patch_emission_.resize(leaves);
  for (int l = 0; l < leaves; ++l) {
    t.layout_.flux_weight[l] = kPi * h.elements()[h.element_of_leaf(l)].exposed;
    t.patch_emission_[l] = h.leaf(l).emission;
  }
  // The specular links after the leaves (eq. H3), over root ids: link_start has the layout's
  // num_patches + 1 entries (there are at least as many leaves as roots), constant past the
  // last root, so that link_unknown(i, k) takes the root ids a ray hit names.
  t.layout_.link_start.assign(leaves + 1, 0);
  if (const RootSpecular* sp = h.op()->specular()) {
    t.layout_.links = sp->links;
    for (int r = 0; r <= leaves; ++r)
      t.layout_.link_start[r] = sp->link_start[std::min(r, h.num_roots())];
    t.layout_.flux_weight.insert(t.layout_.flux_weight.end(), sp->flux_weight.begin(),
                                 sp->flux_weight.end());
  }
  if (const Material* m = brightest_material(materials)) {  // a_max
    t.max_albedo_ = m->albedo_bound().maxCoeff();
    t.brightest_material_ = m->name;
  }
  t.weights_.cols = t.size();
  return t;
}

}  // namespace polyrad
