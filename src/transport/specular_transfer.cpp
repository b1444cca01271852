// The specular transfer R_jik (specular_transfer.h); eq. 8 of papers/glossy-radiosity.md.
#include "polyrad/specular_transfer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>

#include "polyrad/progress.h"
#include "polyrad/sampling.h"

namespace polyrad {

namespace {

// Centre-point entries below this share of the largest are pruned: the seed's estimator is dense
// (every k a lobe can reach), and kept only for comparison.
constexpr double kCentrePointPrune = 1e-4;

void monte_carlo_entries(const PatchSet& patches, const Material& m, const FormFactors& ff,
                         const RayCaster& caster, const SpecularOptions& o, PatchId i,
                         std::vector<TransferEntry>& out, long long& rays, long long& unseen,
                         double& escaped, double& weight) {
  const Patch& pi = patches[i];
  const Frame frame = Frame::from_normal(pi.normal);
  const int side = std::max(1, static_cast<int>(std::lround(std::sqrt(o.samples))));
  const int count = side * side;
  std::map<PatchId, double> hits;  // k -> sum of w * beta
  for (auto f = ff.f.start[i]; f < ff.f.start[i + 1]; ++f) {
    const PatchId j = ff.f.column[f];
    const Patch& pj = patches[j];
    Rng rng(o.seed, static_cast<std::uint64_t>(i), static_cast<std::uint64_t>(j));
    hits.clear();
    double total = 0.0, lost = 0.0;
    for (int s = 0; s < count; ++s) {
      // x stratified on P_i; y on P_j stratified with the strata shuffled by a fixed odd stride.
      int sx = s, sy = (s * 7 + 3) % count;
      double dx, dy;
      Vec3 x = pi.sample(Vec2((sx % side + rng.uniform()) / side, (sx / side + rng.uniform()) / side), &dx);
      Vec3 y = pj.sample(Vec2((sy % side + rng.uniform()) / side, (sy / side + rng.uniform()) / side), &dy);
      Vec2 lobe_u = rng.uniform2();
      Vec3 d = y - x;
      double r2 = d.squaredNorm();
      double r = std::sqrt(r2);
      double cos_x = pi.normal.dot(d) / r, cos_y = -pj.normal.dot(d) / r;
      if (!(cos_x > 0.0 && cos_y > 0.0)) continue;
      ++rays;
      if (caster.segment_occluded(x, y)) continue;
      double w = cos_x * cos_y / r2 * dx * dy;  // G(x, y) V(x, y), area-density corrected
      total += w;
      LobeSample ls = m.lobe_sample(frame.to_local(d / r), lobe_u);
      if (ls.weight <= 0.0) continue;
      ++rays;
      Hit h = caster.intersect(x, frame.to_world(ls.wi), caster.epsilon());
      if (h.valid() && h.front && h.patch != i) hits[h.patch] += w * ls.weight;
      else lost += w * ls.weight;
    }
    if (total <= 0.0) {
      ++unseen;
      continue;
    }
    for (const auto& [k, v] : hits) out.push_back({j, k, static_cast<float>(v / total)});
    escaped += lost;
    weight += total;
  }
}

void centre_point_entries(const PatchSet& patches, const Material& m, const FormFactors& ff,
                          PatchId i, std::vector<TransferEntry>& out) {
  // The seed's estimator: rho at patch centres, R_jik = pi f(c_j, c_k) F_ik (from eq. 7 with
  // S_{i->k} = sum_j f pi F_ij L_{j->i}). Zero for a mirror, whose lobe is a delta.
  const Patch& pi = patches[i];
  const Frame frame = Frame::from_normal(pi.normal);
  size_t first = out.size();
  double largest = 0.0;
  for (auto f = ff.f.start[i]; f < ff.f.start[i + 1]; ++f) {
    PatchId j = ff.f.column[f];
    Vec3 wi = frame.to_local((patches[j].centroid - pi.centroid).normalized());
    for (auto g = ff.f.start[i]; g < ff.f.start[i + 1]; ++g) {
      PatchId k = ff.f.column[g];
      if (k == j) continue;
      Vec3 wo = frame.to_local((patches[k].centroid - pi.centroid).normalized());
      double r = kPi * m.lobe_eval(wi, wo) * ff.f.value[g];
      if (r > 0.0) out.push_back({j, k, static_cast<float>(r)});
      largest = std::max(largest, r);
    }
  }
  auto keep = std::remove_if(out.begin() + first, out.end(), [&](const TransferEntry& e) {
    return e.fraction < kCentrePointPrune * largest;
  });
  out.erase(keep, out.end());
}

}  // namespace

void specular_entries_of(const PatchSet& patches, const Material& material, const FormFactors& ff,
                         const RayCaster& caster, const SpecularOptions& options, PatchId i,
                         std::vector<TransferEntry>& out, long long* rays, long long* unseen,
                         double* escaped, double* weight) {
  long long r = 0, u = 0;
  double e = 0.0, w = 0.0;
  if (options.estimator == SpecularEstimator::kCentrePoint)
    centre_point_entries(patches, material, ff, i, out);
  else
    monte_carlo_entries(patches, material, ff, caster, options, i, out, r, u, e, w);
  if (rays) *rays += r;
  if (unseen) *unseen += u;
  if (escaped) *escaped += e;
  if (weight) *weight += w;
}

SpecularTransfer compute_specular_transfer(const PatchSet& patches,
                                           const std::vector<Material>& materials,
                                           const FormFactors& ff, const RayCaster& caster,
                                           const SpecularOptions& options) {
  auto t0 = std::chrono::steady_clock::now();
  const auto n = static_cast<PatchId>(patches.size());
  std::vector<std::vector<TransferEntry>> per_patch(n);
  long long rays = 0, unseen = 0, pairs = 0;
  double escaped = 0.0, weight = 0.0;
  Progress progress("specular transfer", n);
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : rays, unseen, pairs, escaped, weight)
  for (PatchId i = 0; i < n; ++i) {
    const Material& m = materials[patches[i].material];
    if (m.has_lobe()) {
      pairs += ff.f.start[i + 1] - ff.f.start[i];
      specular_entries_of(patches, m, ff, caster, options, i, per_patch[i], &rays, &unseen,
                          &escaped, &weight);
      // Sorted by (from, to): the order build_transport and the file format expect.
      std::sort(per_patch[i].begin(), per_patch[i].end(), [](const auto& a, const auto& b) {
        return a.from != b.from ? a.from < b.from : a.to < b.to;
      });
    }
    progress.advance();
  }
  progress.finish();

  SpecularTransfer st;
  st.start.assign(n + 1, 0);
  for (PatchId i = 0; i < n; ++i) {
    for (const auto& e : per_patch[i]) {
      st.from.push_back(e.from);
      st.to.push_back(e.to);
      st.fraction.push_back(e.fraction);
    }
    st.start[i + 1] = static_cast<std::int64_t>(st.to.size());
  }
  st.stats.rays = rays;
  st.stats.pairs = pairs;
  st.stats.pairs_unseen = unseen;
  st.stats.escaped_fraction = weight > 0.0 ? escaped / weight : 0.0;
  st.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return st;
}

}  // namespace polyrad
