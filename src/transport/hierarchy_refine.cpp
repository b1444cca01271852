// The refinement oracle (eq. H1 of papers/glossy-radiosity.md, section 12) of the hierarchy's
// builder (hierarchy_builder.h): point form factors, visibility probes, the judgement of each
// candidate pair, and the pair form factors (eq. 4) of the links it keeps.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <span>

#include "hierarchy_builder.h"
#include "polyrad/util/error.h"
#include "polyrad/util/progress.h"
#include "polyrad/util/sampling.h"
#include "polyrad/util/timer.h"

namespace polyrad {

namespace {

// The parameters of the oracle's sample points of an element (as ElementLink's fa, fb).
Vec2 sample_uv(const Element& e, int k) {
  return k < e.shape.corners ? Vec2(e.uv[k] + 0.01 * (e.centroid_uv - e.uv[k])) : e.centroid_uv;
}

// The factor (at most 1) by which slopes must shrink for a linear function of this mean to stay
// non-negative on r.
double non_negative_scale(const Element& r, const Vec2& slope, double mean) {
  const double drop = hierarchy_detail::corner_drop(r, slope);
  return drop > mean ? std::max(mean, 0.0) / drop : 1.0;
}

}  // namespace

using hierarchy_detail::any_corner_in_front;
using hierarchy_detail::fit_linear;
using hierarchy_detail::LinearFit;
using hierarchy_detail::longest_edge;
using hierarchy_detail::point_values;
using hierarchy_detail::SmallPolygon;
using hierarchy_detail::wholly_exposed;

namespace hierarchy_detail {

LinearFit fit_linear(const Element& r, const std::array<float, kOraclePoints>& f) {
  // Least squares of f ~ mean + slope . d over the points' offsets d from the centroid, solved
  // about the points' own mean offset: the slopes from the 2 x 2 centred normal equations, the
  // mean from f's mean. The oracle and the operator's rows fit every link's two ends at every
  // judgement and build, so this is kept to a few multiplications (no 3 x 3 solve).
  std::array<Vec2, kOraclePoints> d;
  Vec2 d_mean = Vec2::Zero();
  double f_mean = 0.0;
  for (int k = 0; k < kOraclePoints; ++k) {
    d[k] = sample_uv(r, k) - r.centroid_uv;
    d_mean += d[k] / kOraclePoints;
    f_mean += static_cast<double>(f[k]) / kOraclePoints;
  }
  double sxx = 0.0, sxy = 0.0, syy = 0.0, sxf = 0.0, syf = 0.0;
  for (int k = 0; k < kOraclePoints; ++k) {
    const Vec2 c = d[k] - d_mean;
    const double g = static_cast<double>(f[k]) - f_mean;
    sxx += c.x() * c.x();
    sxy += c.x() * c.y();
    syy += c.y() * c.y();
    sxf += c.x() * g;
    syf += c.y() * g;
  }
  const double det = sxx * syy - sxy * sxy;  // > 0: the points span the element
  const Vec2 slope =
      det > 0.0 ? Vec2((syy * sxf - sxy * syf) / det, (sxx * syf - sxy * sxf) / det) : Vec2::Zero();
  LinearFit fit{f_mean - slope.dot(d_mean), slope, 0.0};
  for (int k = 0; k < kOraclePoints; ++k)
    fit.miss = std::max(fit.miss, std::abs(f[k] - (fit.mean + fit.slope.dot(d[k]))));
  return fit;
}

void point_values(const Patch& r, const SmallPolygon& s, const Vec3& n_s, const Vec3& c_s,
                  double eps, std::array<float, kOraclePoints>& f) {
  SmallPolygon front;
  clip_front(s, r.centroid, r.normal, front);
  for (int k = 0; k < kOraclePoints; ++k) {
    const Vec3 x = oracle_point(r, k);
    double v = 0.0;
    if (front.n >= 3 && (x - c_s).dot(n_s) > eps)
      v = point_to_polygon_form_factor(x, r.normal, std::span<const Vec3>(front.v.data(), front.n));
    f[k] = static_cast<float>(v);
  }
}

}  // namespace hierarchy_detail

// dF of eq. H1 for receiver `r` of link l (r is l.a or l.b).
double HierarchyBuilder::spread(const ElementLink& l, std::int32_t r) const {
  if (l.visibility == LinkVisibility::kHidden) return 0.0;
  const auto& f = r == l.a ? l.fa : l.fb;
  if (l.visibility == LinkVisibility::kUntested) return *std::max_element(f.begin(), f.end());
  // What a link gives r is the fitted linear function, its slopes shrunk where it would go
  // negative: it misses the point values (times their visible fractions, for a partly hidden
  // pair) by the fit's miss plus what the shrinking took. Judged at r's own corners alone: the
  // operator bounds both ends' slopes together but over the boxes of their leaves' centroids
  // (hierarchy_make_operator.cpp, leaf_drop), so it may shrink more or less than this says.
  const Element& e = el_[r];
  const LinearFit fit = fit_linear(e, f);
  const double scale = non_negative_scale(e, fit.slope, fit.mean);
  double reach = 0.0;
  for (int k = 0; k < e.shape.corners; ++k)
    reach = std::max(reach, std::abs(fit.slope.dot(e.uv[k] - e.centroid_uv)));
  return fit.miss + (1.0 - scale) * reach;
}

// Eq. H1 for receiver r of link l (r is l.a or l.b), per channel c, against what r receives:
// - wholly visible: what the linear function misses of the point values, dF_rs, within the
//   tolerance's share of what the link carries,
//       rho_r B_s dF_rs <= tau rho_r F_rs max(B_s, kDarkest B_ref)
//   (F_rs estimated by the mean of the point values), so that the misses of all the links a
//   leaf reads, which near a wall share one sign, add up to about tau of its light; or the
//   link is negligible: rho_r B_s F_rs <= kNegligible tau max(B_r, kDarkest B_ref);
// - not yet tested by rays: the same with dF = F_max (linked without rays only then);
// - partly hidden: the shadow may put all of it anywhere (the visible fractions at the points
//   shape the linear function but are too noisy to judge it by):
//       rho_r B_s F_max <= tau max(B_r, kDarkest B_ref),
//   a share of r's own radiosity, so a shadow is refined until it is a small part of the
//   light where it falls;
// - hidden: linked as it is, never refined.
// A source in a reflector's tree shines toward r with B_s + S_{root(s)->root(r)} (eq. H3 (a)),
// as the last solve found it.
bool HierarchyBuilder::accurate_for(const ElementLink& l, std::int32_t r) const {
  const auto& f = r == l.a ? l.fa : l.fb;
  const std::int32_t source = r == l.a ? l.b : l.a;
  // Along an image link the source shines s_q (B_s + S_{root(s)->m}), m the mirror root its path
  // crosses (eq. H4), toward a receiver without a lobe only.
  if (l.mirror >= 0 && !takes_images(r)) return true;
  const Eigen::Array3d b =
      l.mirror >= 0
          ? Eigen::Array3d(
                h_.mirrors_.planes[l.mirror].specular *
                (b_[source] + specular_toward(el_[source].root, crossing_root(l.a, l.b, l.mirror))))
          : Eigen::Array3d(b_[source] + specular_toward(el_[source].root, el_[r].root));
  // A receiver with a lobe passes on what it gathers with d + s, and shines with B_r plus its
  // links' mean S: judged so, a mirror and a wall are refined as two walls would be (the
  // five points of one end miss the kernel's rise along a shared edge that splitting the
  // other end reveals).
  const Eigen::Array3d& rho = judged_rho_[el_[r].root];
  const Eigen::Array3d b_r = b_[r] + mean_s_[el_[r].root];
  const double tau = o_.tolerance();
  if (l.visibility == LinkVisibility::kHidden) return true;
  if (l.visibility == LinkVisibility::kPartial) {
    const double f_max = r == l.a ? l.fmax_a : l.fmax_b;
    for (int c = 0; c < 3; ++c)
      if (rho[c] * b[c] * f_max > tau * std::max(b_r[c], kDarkest * b_ref_)) return false;
    return true;
  }
  const double d = spread(l, r);
  if (!(d > 0.0)) return true;
  double mean = 0.0;
  for (float v : f) mean += v / kOraclePoints;
  for (int c = 0; c < 3; ++c) {
    if (!(rho[c] > 0.0)) continue;
    const double floor = kDarkest * b_ref_;
    if (d * b[c] <= tau * mean * std::max(b[c], floor)) continue;  // relative to the link
    if (rho[c] * b[c] * mean <= kNegligible * tau * std::max(b_r[c], floor)) continue;
    return false;
  }
  return true;
}

std::uint64_t HierarchyBuilder::pair_key(std::int32_t a, std::int32_t b) const {
  const auto n = static_cast<std::uint64_t>(roots_.size());
  if (el_[a].parent < 0 && el_[b].parent < 0) {  // two roots: the uniform mesh's key
    const auto i = static_cast<std::uint64_t>(std::min(a, b)),
               j = static_cast<std::uint64_t>(std::max(a, b));
    return i * n + j;
  }
  const std::uint64_t ka = el_[a].key, kb = el_[b].key;
  return mix64(std::min(ka, kb)) ^ std::max(ka, kb);
}

bool HierarchyBuilder::point_form_factors(std::int32_t a, std::int32_t b, ElementLink& l) const {
  const Patch &pa = el_[a].shape, &pb = el_[b].shape;
  const double eps = 1e-9 * std::max(pa.diameter(), pb.diameter());
  if (!any_corner_in_front(pb, pa, eps) || !any_corner_in_front(pa, pb, eps)) return false;
  l.a = a;
  l.b = b;
  point_values(pa, SmallPolygon(pb), pb.normal, pb.centroid, eps, l.fa);
  point_values(pb, SmallPolygon(pa), pa.normal, pa.centroid, eps, l.fb);
  return true;
}

PatchExposure HierarchyBuilder::exposure_of(std::int32_t e) const {
  const Element& el = el_[e];
  PatchExposure x(el.shape.area > 0.0 ? el.exposed / el.shape.area : 0.0);
  if (x.fraction > 0.0 && !x.wholly()) {
    const auto [map, index] = exposure_at_[e];
    if (map >= 0) {
      const PatchExposure grid = exposure_maps_[map][index];
      x.n = grid.n;
      x.cells = grid.cells;
    }
  }
  return x;
}

int HierarchyBuilder::probe_rays(std::int32_t a, std::int32_t b) const {
  // Whole parts a side, so that the count stays a square (16 n^2, coprime to the shuffle's 5):
  // the strata tile both elements, each stratum once.
  auto side = [&](std::int32_t e) {
    const double ratio = longest_edge(el_[e].shape) / (8.0 * min_size_[el_[e].root]);
    if (!(ratio > 1.0)) return 1;
    return static_cast<int>(std::ceil(std::min(ratio, double{kMaxProbeSide}) - 1e-9));
  };
  const int n = std::max(side(a), side(b));
  return std::max(1, o_.visibility_rays) * n * n;
}

LinkVisibility HierarchyBuilder::probe(ElementLink& l, long long* rays) const {
  // Stratified point pairs keyed by the pair, until both outcomes have been seen.
  const std::int32_t a = l.a, b = l.b;
  const Patch &pa = el_[a].shape, &pb = el_[b].shape;
  const int m = probe_rays(a, b);
  const int side = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(m))));
  Rng rng(o_.seed, link_key(a, b, l.mirror));
  // On a partly buried element, points inside other geometry are skipped: they see nothing and
  // no one sees them, which is not a shadow (their area is not in A').
  const bool buried_a = !wholly_exposed(el_[a]), buried_b = !wholly_exposed(el_[b]);
  const PatchExposure exposure_a = exposure_of(a), exposure_b = exposure_of(b);
  int blocked = 0, open = 0;
  for (int k = 0; k < m && !(blocked > 0 && open > 0); ++k) {
    const double u0 = rng.uniform32(), v0 = rng.uniform32();
    const double u1 = rng.uniform32(), v1 = rng.uniform32();
    const int k2 = (k * 5 + 3) % m;  // the other end's stratum, shuffled against this one's
    double density;
    const Vec3 x =
        pa.sample(Vec2((k % side + u0) / side, ((k / side) % side + v0) / side), &density);
    Vec3 y;
    if (!target_through(l, a, b, x, Vec2((k2 % side + u1) / side, ((k2 / side) % side + v1) / side),
                        &y))
      continue;
    if ((buried_a && !exposure_a.exposed_at(pa, x, caster_)) ||
        (buried_b && !exposure_b.exposed_at(pb, y, caster_)))
      continue;
    const Path path = path_between(l, x, pa, y, pb, rays);
    if (path == Path::kOpen) ++open;
    if (path == Path::kBlocked) ++blocked;
  }
  // An image link whose rays all missed the mirror's outline has been tested for nothing: it
  // stays untested, so that its parts are probed again (a wholly visible verdict would be
  // final for them).
  if (l.mirror >= 0 && open == 0 && blocked == 0) return LinkVisibility::kUntested;
  if (open == 0) return LinkVisibility::kHidden;
  if (blocked == 0) return LinkVisibility::kVisible;  // (also when every point was buried)
  // Partly hidden: the point values weighed by their visible fractions.
  l.fmax_a = *std::max_element(l.fa.begin(), l.fa.end());
  l.fmax_b = *std::max_element(l.fb.begin(), l.fb.end());
  weigh_by_visibility(l, 0, exposure_b, l.fa, rays);
  weigh_by_visibility(l, 1, exposure_a, l.fb, rays);
  return LinkVisibility::kPartial;
}

// Partly hidden: each oracle point's value times its visible fraction, from kPointRays rays
// to stratified points of the other element, so that the linear function follows a penumbra
// and the miss measures what it cannot follow.
void HierarchyBuilder::weigh_by_visibility(const ElementLink& l, int which,
                                           const PatchExposure& exposure_to,
                                           std::array<float, kOraclePoints>& f,
                                           long long* rays) const {
  const std::int32_t a = l.a, b = l.b;
  const Patch& from = el_[which == 0 ? a : b].shape;
  const Patch& to = el_[which == 0 ? b : a].shape;
  const bool buried_to = !wholly_exposed(el_[which == 0 ? b : a]);
  ImageView view;  // an image link's, one a point
  for (int k = 0; k < kOraclePoints; ++k) {
    if (!(f[k] > 0.0f)) continue;
    const Vec3 x = hierarchy_detail::oracle_point(from, k);
    Rng point(o_.seed, link_key(a, b, l.mirror), which * kOraclePoints + k + 1);
    if (l.mirror >= 0) image_view(l, which == 0 ? a : b, which == 0 ? b : a, x, &view);
    int seen = 0, cast = 0;
    for (int j = 0; j < kPointRays; ++j) {
      const double u = point.uniform32(), v = point.uniform32();
      const Vec2 s((j % 2 + u) / 2.0, (j / 2 + v) / 2.0);
      Vec3 y;
      if (l.mirror >= 0 ? !view.draw(s, &y)
                        : !target_through(l, which == 0 ? a : b, which == 0 ? b : a, x, s, &y))
        continue;
      if (buried_to && !exposure_to.exposed_at(to, y, caster_)) continue;
      const Path path = path_between(l, x, from, y, to, rays);
      if (path == Path::kOutside) continue;
      ++cast;
      if (path == Path::kOpen) ++seen;
    }
    // (An image link's rays that all missed the mirror leave its exact value as it is.)
    f[k] *= cast > 0 ? static_cast<float>(seen) / cast : (l.mirror >= 0 ? 1.0f : 0.0f);
  }
}

HierarchyBuilder::Outcome HierarchyBuilder::judge(const Candidate& c) const {
  const std::int32_t a = c.a, b = c.b;
  Outcome out;
  if (!(el_[a].exposed > 0.0) || !(el_[b].exposed > 0.0)) return out;
  ElementLink& l = out.link;
  if (c.mirror >= 0 ? !image_point_form_factors(a, b, c.mirror, l) : !point_form_factors(a, b, l))
    return out;
  out.decision = kLink;
  if (c.visibility == LinkVisibility::kVisible) {
    l.visibility = c.visibility;
  } else {
    // Below the tolerance even as a partly hidden pair: link without casting a ray.
    if (accurate(l)) return out;
    out.probed = true;
    // Hidden as far as the rays tell: link at this level (its pair form factor finds whatever
    // the rays missed) and never refine it.
    l.visibility = probe(l, &out.rays);
  }
  if (l.visibility == LinkVisibility::kHidden || accurate(l)) return out;
  const std::int32_t s = split_choice(a, b);
  out.decision = s < 0 ? kLink : (s == a ? kSplitA : kSplitB);
  return out;
}

void HierarchyBuilder::refine(std::vector<Candidate> candidates, HierarchyPass& pass) {
  const Stopwatch t0;
  const double exposure0 = h_.stats_.exposure_seconds;
  while (!candidates.empty()) {
    const Decisions decided = judge_all(candidates, pass);
    pass.candidates += static_cast<std::int64_t>(candidates.size());
    candidates = split_decided(candidates, decided, pass);
  }
  pass.oracle_seconds += oracle_seconds_since(t0, exposure0);
}

void HierarchyBuilder::require_link_memory() const {
  if (!(o_.max_link_bytes > 0.0)) return;
  double links = 0.0;
  for (const LinkChunks* chunks : {&links_, &pending_})
    for (const auto& chunk : *chunks) links += static_cast<double>(chunk.size());
  const double bytes = links * HierarchyOptions::kLinkBytesFloor;
  if (bytes <= o_.max_link_bytes) return;
  constexpr double gib = 1 << 30;
  char text[400];
  std::snprintf(text, sizeof text,
                "the hierarchy refined to %.3g links, at least %.3g GiB, past the %.3g GiB the "
                "memory budget leaves its links (the light asked for more than the estimate "
                "foresaw); use a larger link tolerance or smallest element, or raise "
                "--max-memory",
                links, bytes / gib, o_.max_link_bytes / gib);
  throw InputError(text);
}

// Judged in batches, so that the outcomes (each with a link's oracle data) are never held for
// every candidate at once; each batch's links become one chunk.
HierarchyBuilder::Decisions HierarchyBuilder::judge_all(const std::vector<Candidate>& candidates,
                                                        HierarchyPass& pass) {
  constexpr std::int64_t kBatch = std::int64_t{1} << 15;
  const auto count = static_cast<std::int64_t>(candidates.size());
  Decisions decided(count);
  std::vector<Outcome> outcome;
  for (std::int64_t first = 0; first < count; first += kBatch) {
    const std::int64_t n = std::min(kBatch, count - first);
    outcome.assign(n, Outcome{});
    long long rays = 0, probes = 0;
#pragma omp parallel for schedule(dynamic, 64) reduction(+ : rays, probes)
    for (std::int64_t k = 0; k < n; ++k) {
      outcome[k] = judge(candidates[first + k]);
      rays += outcome[k].rays;
      probes += outcome[k].probed ? 1 : 0;
    }
    pass.visibility_tests += probes;
    h_.stats_.oracle_rays += rays;
    keep_links(candidates, first, outcome, decided);
    require_link_memory();  // after each batch: one level can hold most of the links
  }
  return decided;
}

// The decisions on a batch of candidates from `first` on, and its links as one chunk of pending_.
void HierarchyBuilder::keep_links(const std::vector<Candidate>& candidates, std::int64_t first,
                                  const std::vector<Outcome>& outcome, Decisions& decided) {
  const auto n = static_cast<std::int64_t>(outcome.size());
  std::vector<KeptLink> chunk;
  chunk.reserve(static_cast<std::size_t>(std::count_if(
      outcome.begin(), outcome.end(), [](const Outcome& o) { return o.decision == kLink; })));
  for (std::int64_t k = 0; k < n; ++k) {
    decided[first + k] = {outcome[k].decision, outcome[k].link.visibility};
    if (outcome[k].decision != kLink) continue;
    chunk.push_back(KeptLink::keep(outcome[k].link));
    // A link judged again keeps its form factor where the same rules would integrate it
    // again; one linked without rays whose rays now found a shadow below the roots is
    // integrated again with the full count.
    const Candidate& c = candidates[first + k];
    KeptLink& kept = chunk.back();
    kept.m = c.m >= 0.0f && open_rules(c.a, c.b, c.visibility) ==
                                open_rules(kept.a, kept.b, kept.visibility)
                 ? c.m
                 : -1.0f;
  }
  if (!chunk.empty()) pending_.push_back(std::move(chunk));
}

// The ends the oracle chose are split; their children, each with the other end, are the next
// candidates.
std::vector<HierarchyBuilder::Candidate> HierarchyBuilder::split_decided(
    const std::vector<Candidate>& candidates, const Decisions& decided, HierarchyPass& pass) {
  const auto count = static_cast<std::int64_t>(candidates.size());
  std::vector<std::int32_t> to_split;
  for (std::int64_t k = 0; k < count; ++k) {
    if (decided[k].first == kSplitA) to_split.push_back(candidates[k].a);
    if (decided[k].first == kSplitB) to_split.push_back(candidates[k].b);
  }
  split_all(to_split, pass);
  std::vector<Candidate> next;
  for (std::int64_t k = 0; k < count; ++k) {
    const Candidate& c = candidates[k];
    const auto [decision, visibility] = decided[k];
    if (decision == kSplitA) split_pair(c, c.a, visibility, next);
    if (decision == kSplitB) split_pair(c, c.b, visibility, next);
  }
  return next;
}

void HierarchyBuilder::link_form_factors(HierarchyPass& pass) {
  const Stopwatch t0;
  std::int64_t total = 0;
  for (const auto& chunk : pending_) total += static_cast<std::int64_t>(chunk.size());
  long long rays = 0;
  FormFactorOptions open_form_factors = o_.form_factors;  // never more rays than the full count
  open_form_factors.visibility_rays =
      std::min(o_.form_factors.visibility_rays, std::max(1, o_.open_link_rays));
  Progress progress("hierarchy form factors", total);
  for (auto& chunk : pending_) {
    const auto count = static_cast<std::int64_t>(chunk.size());
#pragma omp parallel for schedule(dynamic, 16) reduction(+ : rays)
    for (std::int64_t k = 0; k < count; ++k) {
      KeptLink& l = chunk[k];
      if (l.m >= 0.0f) continue;  // judged again after its rays and kept: its form factor is known
      // Integrate over the smaller element, as the uniform mesh does (with its key for two roots,
      // so that a tree of one level reproduces the uniform system exactly).
      std::int32_t x = l.a, y = l.b;
      const bool roots = el_[x].parent < 0 && el_[y].parent < 0;
      if (roots) {
        const std::int32_t i = std::min(x, y), j = std::max(x, y);
        x = el_[i].shape.area <= el_[j].shape.area ? i : j;
        y = x == i ? j : i;
      } else if (el_[y].shape.area < el_[x].shape.area ||
                 (el_[y].shape.area == el_[x].shape.area && el_[y].key < el_[x].key)) {
        std::swap(x, y);
      }
      const Element& ex = el_[x];
      long long r = 0;
      const double g = l.mirror() >= 0 ? image_pair_form_factor(x, y, l.mirror(), l.visibility, &r)
                                       : pair_area_form_factor(ex.shape, el_[y].shape, &caster_,
                                                               open_rules(l.a, l.b, l.visibility)
                                                                   ? open_form_factors
                                                                   : o_.form_factors,
                                                               pair_key(x, y), &r, exposure_of(x));
      rays += r;
      if (x != l.a) l.swap_ends();
      l.m = g > 0.0 && ex.exposed > 0.0 ? static_cast<float>(g / ex.exposed) : 0.0f;
      if (k % 256 == 0) progress.advance(256);
    }
  }
  progress.finish();
  h_.stats_.form_factor_rays += rays;
  // Into the links chunk by chunk, without a copy of them.
  for (auto& chunk : pending_) {
    std::erase_if(chunk, [](const KeptLink& l) { return !(l.m > 0.0f); });
    chunk.shrink_to_fit();
    if (!chunk.empty()) links_.push_back(std::move(chunk));
  }
  LinkChunks().swap(pending_);
  pass.form_factor_seconds += t0.seconds();
}

}  // namespace polyrad
