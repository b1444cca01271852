// The specular transfer R_jik (specular_transfer.h); eq. 8 and 9 of papers/glossy-radiosity.md.
#include "polyrad/transport/specular_transfer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>

#include "polyrad/util/machine.h"
#include "polyrad/util/progress.h"
#include "polyrad/util/sampling.h"
#include "polyrad/util/timer.h"

namespace polyrad {

namespace {

// Centre-point entries below this share of the largest are pruned: the seed's estimator is dense
// (every k a lobe can reach), and kept only for comparison.
constexpr double kCentrePointPrune = 1e-4;
// The most sweeps of the balance's ascent before it is taken as not settling (then the prior
// below makes the problem well posed). Every balance of cornell-glossy, the room and the mirror
// cube at patch sizes 25 and 17 (1,454 of them, the second ascents with the prior among them)
// settled within the 30 sweeps before Newton or by Newton there, or not in 3,000 either; at 3,000
// the 42 that did not were nine tenths of the ascent's sweeps at patch size 17 (126,000 of
// 141,000).
constexpr int kBalanceIterations = 300;
constexpr double kBalanceTolerance = 1e-9;
constexpr double kLostPrior = 1e-4;
// Sweeps of coordinate ascent before Newton's method takes over, its most steps, and the most
// conjugate-gradient iterations of a step.
constexpr int kSweepsBeforeNewton = 30;
constexpr int kNewtonSteps = 40;
constexpr int kNewtonIterations = 200;

// The first of 7, 11, 13, ... that shares no factor with n: s -> (s * stride + 3) mod n is then
// a permutation of 0..n-1.
int coprime_stride(int n) {
  for (int stride : {7, 11, 13, 17, 19, 23, 29, 31})
    if (std::gcd(stride, n) == 1) return stride;
  return 1;
}

// What the samples of one pair (j -> i) measured: the fractions R_jik and the total reflected
// fraction A_j = sum_k R_jik.
struct SampledPair {
  PatchId from = 0;
  double reflected = 0.0;
  double effective_samples = 0.0;                    // (sum w)^2 / sum w^2
  std::vector<std::pair<PatchId, double>> fraction;  // by k
};

// Eq. 8 for every pair (j -> i) of reflector i; hits on patches i does not see by its form
// factors (F_ik = 0, a sliver the form-factor rays missed) are dropped and counted.
void monte_carlo_pairs(const PatchSet& patches, const Material& m, const FormFactors& ff,
                       const RayCaster& caster, const SpecularOptions& o, PatchId i,
                       std::vector<SampledPair>& out, TransferCounters& counters) {
  const Patch& pi = patches[i];
  const Frame frame = Frame::from_normal(pi.normal);
  const int side = std::max(1, static_cast<int>(std::lround(std::sqrt(o.samples))));
  const int count = side * side;
  const int stride = coprime_stride(count);
  std::map<PatchId, double> hits;  // k -> sum of w * beta
  for (auto [j, f_ij] : ff.f.row(i)) {
    const Patch& pj = patches[j];
    Rng rng(o.seed, static_cast<std::uint64_t>(i), static_cast<std::uint64_t>(j));
    hits.clear();
    double reflected = 0.0;  // sum of w * beta of rays that met a patch i sees
    double w1 = 0.0, w2 = 0.0, lost = 0.0;
    for (int s = 0; s < count; ++s) {
      // x stratified on P_i; y on P_j stratified too, its strata visited in another order (a
      // stride coprime with the count, so that every stratum is used exactly once).
      int sx = s, sy = (s * stride + 3) % count;
      // One draw a statement (a call's arguments are unsequenced), each point's second
      // coordinate first: the order GCC gave every figure measured before this was written out.
      double dx, dy;
      const double xv = rng.uniform(), xu = rng.uniform();
      Vec3 x = pi.sample(Vec2((sx % side + xu) / side, (sx / side + xv) / side), &dx);
      const double yv = rng.uniform(), yu = rng.uniform();
      Vec3 y = pj.sample(Vec2((sy % side + yu) / side, (sy / side + yv) / side), &dy);
      Vec2 lobe_u = rng.uniform2();
      Vec3 d = y - x;
      double r2 = d.squaredNorm();
      double r = std::sqrt(r2);
      double cos_x = pi.normal.dot(d) / r, cos_y = -pj.normal.dot(d) / r;
      if (!(cos_x > 0.0 && cos_y > 0.0)) continue;
      ++counters.rays;
      if (caster.segment_occluded(x, i, y, j)) continue;
      double w = cos_x * cos_y / r2 * dx * dy;  // G(x, y) V(x, y), area-density corrected
      w1 += w;
      w2 += w * w;
      LobeSample ls = m.lobe_sample(frame.to_local(d / r), lobe_u);
      if (ls.weight <= 0.0) continue;
      ++counters.rays;
      Hit h = caster.intersect_from(x, i, frame.to_world(ls.wi));
      if (h.valid() && h.front && h.patch != i && ff.at(i, h.patch) > 0.0) {
        hits[h.patch] += w * ls.weight;
        reflected += w * ls.weight;
      } else {
        if (h.valid() && h.front && h.patch != i) ++counters.dropped;
        lost += w * ls.weight;
      }
    }
    if (w1 <= 0.0) {
      ++counters.unseen;
      continue;
    }
    SampledPair p;
    p.from = j;
    p.reflected = reflected / w1;
    p.effective_samples = w1 * w1 / w2;
    for (const auto& [k, sum] : hits) p.fraction.emplace_back(k, sum / w1);
    out.push_back(std::move(p));
    counters.escaped += lost;
    counters.weight += w1;
  }
}

namespace balance {

// One row of the dual problem: lambda_a with r_a(lambda) = sum_b C_ab / (lambda_a + lambda_b)
// (+ c_aa / lambda_a on the diagonal).
struct Row {
  double tau = 0.0;   // tau_ia: the most the row may carry
  double lost = 0.0;  // c_aE
  double diag = 0.0;  // c_aa
  double lambda = 0.0;
  double start = 0.0;  // n_a / tau_a, where the ascent begins
  bool observed = false;
  std::vector<std::pair<int, double>> partner;  // (b, C_ab) for b != a
};

// r_a(lambda) and its derivative.
std::pair<double, double> row_sum(const std::vector<Row>& rows, const Row& r, double lambda) {
  double s = 0.0, ds = 0.0;
  if (r.diag > 0.0) {
    s = r.diag / lambda;
    ds = -s / lambda;
  }
  for (const auto& [b, c] : r.partner) {
    double q = 1.0 / (lambda + rows[b].lambda);
    s += c * q;
    ds -= c * q * q;
  }
  return {s, ds};
}

// Solves row a's stationarity condition for lambda_a, the others fixed:
//   lost > 0:  lambda (tau - r(lambda)) = lost     (lambda > 0)
//   lost = 0:  r(lambda) = tau                      (any lambda keeping denominators positive)
// Both residuals decrease as lambda falls toward the pole where a denominator vanishes and
// r -> infinity, and grow past zero as lambda rises, so a bracket exists; safeguarded Newton
// finds the root in a few steps.
double solve_row(const std::vector<Row>& rows, const Row& r) {
  double pole = r.diag > 0.0 ? 0.0 : -std::numeric_limits<double>::infinity();
  for (const auto& [b, c] : r.partner) pole = std::max(pole, -rows[b].lambda);
  if (r.lost > 0.0) pole = std::max(pole, 0.0);
  // residual > 0: lambda too large is impossible here; residual < 0 means lambda too small.
  auto residual = [&](double lambda) -> std::pair<double, double> {
    auto [sum, dsum] = row_sum(rows, r, lambda);
    if (r.lost <= 0.0) return {r.tau - sum, -dsum};
    return {lambda * (r.tau - sum) - r.lost, (r.tau - sum) - lambda * dsum};
  };
  // Bracket [lo, hi] with residual(lo) < 0 < residual(hi).
  double scale = std::max({std::abs(r.lambda), std::abs(r.start), 1e-300});
  double lo = std::isfinite(pole) ? pole : r.lambda - scale;
  while (!std::isfinite(pole) && residual(lo).first >= 0.0) lo -= (scale *= 2.0);
  double hi = std::max(r.lambda, lo) + scale;
  while (residual(hi).first <= 0.0) hi += (scale *= 2.0);
  double x = std::clamp(r.lambda, lo, hi);
  if (x <= lo || x >= hi) x = 0.5 * (lo + hi);
  for (int it = 0; it < 100; ++it) {
    auto [f, df] = residual(x);
    if (f == 0.0) return x;
    (f < 0.0 ? lo : hi) = x;
    double next = df > 0.0 ? x - f / df : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - x) <= 1e-14 * std::abs(x) || next == lo || next == hi) return next;
    x = next;
  }
  return x;
}

// How far row a is from its stationarity condition, relative.
double residual_of(const std::vector<Row>& rows, const Row& r) {
  double sum = row_sum(rows, r, r.lambda).first;
  if (r.lost > 0.0) return std::abs(r.lambda * (r.tau - sum) / r.lost - 1.0);
  return std::abs(sum / r.tau - 1.0);
}

bool active(const Row& r) { return r.observed && !(r.partner.empty() && r.diag <= 0.0); }

double worst_residual(const std::vector<Row>& rows) {
  double worst = 0.0;
  for (const Row& r : rows)
    if (active(r)) worst = std::max(worst, residual_of(rows, r));
  return worst;
}

// Every row's condition in one form, F_a = tau_a - (c_aa + c_aE) / lambda_a - sum_b C_ab /
// (lambda_a + lambda_b) = 0 (lost = 0 gives r_a = tau_a, lost > 0 the condition above divided
// by lambda_a), relative to tau_a; 0 for the rows not solved for. False outside the domain (a
// denominator not positive).
bool conditions(const std::vector<Row>& rows, const std::vector<double>& lambda,
                std::vector<double>& f) {
  f.assign(rows.size(), 0.0);
  for (std::size_t a = 0; a < rows.size(); ++a) {
    const Row& r = rows[a];
    if (!active(r)) continue;
    const double own = r.diag + r.lost;
    if (own > 0.0 && !(lambda[a] > 0.0)) return false;
    double sum = own > 0.0 ? own / lambda[a] : 0.0;
    for (const auto& [b, c] : r.partner) {
      const double d = lambda[a] + lambda[b];
      if (!(d > 0.0)) return false;
      sum += c / d;
    }
    f[a] = 1.0 - sum / r.tau;
  }
  return true;
}

double norm(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x * x;
  return std::sqrt(s);
}

// The Jacobian of tau F (below) at lambda: row a's diagonal entry, and out = J v given those
// entries (the rows not solved for hold their lambdas, so their entries are 0).
double jacobian_diagonal(const std::vector<Row>& rows, const std::vector<double>& lambda,
                         std::size_t a) {
  const Row& r = rows[a];
  const double own = r.diag + r.lost;
  double d = own > 0.0 ? own / (lambda[a] * lambda[a]) : 0.0;
  for (const auto& [b, c] : r.partner) d += c / ((lambda[a] + lambda[b]) * (lambda[a] + lambda[b]));
  return d;
}

void jacobian_times(const std::vector<Row>& rows, const std::vector<double>& lambda,
                    const std::vector<double>& diagonal, const std::vector<double>& v,
                    std::vector<double>& out) {
  for (std::size_t a = 0; a < rows.size(); ++a) {
    out[a] = 0.0;
    if (!active(rows[a])) continue;
    double s = diagonal[a] * v[a];
    for (const auto& [b, c] : rows[a].partner)
      if (active(rows[b])) s += c / ((lambda[a] + lambda[b]) * (lambda[a] + lambda[b])) * v[b];
    out[a] = s;
  }
}

// Solves J x = g by conjugate gradients from 0, preconditioned by J's diagonal, to a relative
// residual `tolerance` or kNewtonIterations iterations: an inexact Newton step, loose while F is
// large, so that a J that is singular (the sampled pattern allows no lossless solution, which
// the prior settles) costs a bounded number of products.
void conjugate_gradients(const std::vector<Row>& rows, const std::vector<double>& lambda,
                         const std::vector<double>& g, double tolerance, std::vector<double>& x) {
  const std::size_t n = rows.size();
  std::vector<double> jaa(n, 0.0), diag(n, 1.0);  // J's diagonal, and the preconditioner's
  for (std::size_t a = 0; a < n; ++a) {
    if (active(rows[a])) jaa[a] = jacobian_diagonal(rows, lambda, a);
    if (jaa[a] > 0.0) diag[a] = jaa[a];
  }
  x.assign(n, 0.0);
  std::vector<double> res = g, z(n), p(n), q(n);
  double rz = 0.0;
  for (std::size_t a = 0; a < n; ++a) {
    z[a] = p[a] = res[a] / diag[a];
    rz += res[a] * z[a];
  }
  const double g_norm = norm(g);
  for (int it = 0; it < kNewtonIterations && norm(res) > tolerance * g_norm; ++it) {
    jacobian_times(rows, lambda, jaa, p, q);
    double pq = 0.0;
    for (std::size_t a = 0; a < n; ++a) pq += p[a] * q[a];
    if (!(pq > 0.0)) break;
    const double alpha = rz / pq;
    double rz_next = 0.0;
    for (std::size_t a = 0; a < n; ++a) {
      x[a] += alpha * p[a];
      res[a] -= alpha * q[a];
      z[a] = res[a] / diag[a];
      rz_next += res[a] * z[a];
    }
    const double beta = rz_next / rz;
    rz = rz_next;
    for (std::size_t a = 0; a < n; ++a) p[a] = z[a] + beta * p[a];
  }
}

// Newton's method on the conditions of eq. 9, for a reflector whose coordinate ascent settles
// slowly (the room's floor patches, with about 2,000 sources each, took up to 3,000 sweeps). The
// Jacobian of tau_a F_a is symmetric and weakly diagonally dominant with positive entries,
//   J_ab = C_ab / (lambda_a + lambda_b)^2,  J_aa = (c_aa + c_aE) / lambda_a^2 + sum_b J_ab,
// so each step solves J delta = -tau F by conjugate gradients and is halved until it stays in
// the domain and lowers |F|. The lambdas are kept after every step taken. Returns whether every
// row settled (else the caller goes on with the ascent from there).
bool newton(std::vector<Row>& rows) {
  const std::size_t n = rows.size();
  std::vector<double> lambda(n), f, f_trial, trial(n), g(n), delta;
  for (std::size_t a = 0; a < n; ++a) lambda[a] = rows[a].lambda;
  if (!conditions(rows, lambda, f)) return false;
  for (int step = 0; step < kNewtonSteps; ++step) {
    const double f_norm = norm(f);
    for (std::size_t a = 0; a < n; ++a) g[a] = -rows[a].tau * f[a];
    conjugate_gradients(rows, lambda, g, std::clamp(f_norm, 1e-12, 0.1), delta);
    bool moved = false;
    for (double t = 1.0; t > 1e-6 && !moved; t *= 0.5) {
      for (std::size_t a = 0; a < n; ++a) trial[a] = lambda[a] + t * delta[a];
      moved = conditions(rows, trial, f_trial) && norm(f_trial) < (1.0 - 1e-4 * t) * f_norm;
    }
    if (!moved) return false;
    lambda.swap(trial);
    f.swap(f_trial);
    for (std::size_t a = 0; a < n; ++a) rows[a].lambda = lambda[a];
    if (!(worst_residual(rows) >= kBalanceTolerance)) return true;
  }
  return false;
}

// Coordinate ascent over the observed rows, with Newton steps once it is slow; returns the
// largest residual left.
double ascend(std::vector<Row>& rows) {
  double worst = 0.0;
  for (int sweep = 0; sweep < kBalanceIterations; ++sweep) {
    for (Row& r : rows) {
      if (!active(r)) continue;
      double next = solve_row(rows, r);
      if (!std::isfinite(next)) return std::numeric_limits<double>::infinity();
      r.lambda = next;
    }
    worst = worst_residual(rows);
    if (!(worst >= kBalanceTolerance)) break;  // also leaves on NaN
    // Slow: Newton's method from here; if it does not settle every row, the sweeps go on from
    // where it left the lambdas.
    if (sweep + 1 == kSweepsBeforeNewton && newton(rows)) {
      worst = worst_residual(rows);
      break;
    }
  }
  return std::isfinite(worst) ? worst : std::numeric_limits<double>::infinity();
}

}  // namespace balance

// Eq. 9: the maximum-likelihood symmetric flux matrix of reflector i.
//
// Source j's n_j (effective) samples are a multinomial draw: to each k with probability
// M_jk / tau_ij, lost (escaped, or absorbed by beta < 1) with the rest. The counts are
// c_jk = n_j R_jik and c_jE = n_j (1 - sum_k R_jik). Maximising the likelihood over symmetric M
// (reciprocity) gives m_jk = (c_jk + c_kj) / (lambda_j + lambda_k), with lambda_j such that
// lambda_j (tau_ij - sum_k m_jk) = c_jE. The lambdas maximise a concave dual; coordinate ascent
// (solve_row for each source in turn) converges to them. Rows never exceed tau_ij (energy is
// conserved); in a closed scene, where no source loses a ray, every row, hence by symmetry every
// column, carries what its own samples saw (up to the prior below), so each link radiance is
// exact in a uniform field.
double balance_reciprocity(const std::vector<SampledPair>& pairs,
                           const std::vector<std::pair<PatchId, double>>& tau,
                           std::vector<TransferEntry>& out) {
  auto local = [&](PatchId p) {
    auto it = std::lower_bound(tau.begin(), tau.end(), p,
                               [](const auto& e, PatchId key) { return e.first < key; });
    return static_cast<int>(it - tau.begin());
  };
  const int n = static_cast<int>(tau.size());
  std::vector<balance::Row> rows(n);
  std::map<std::pair<int, int>, double> counts;  // C_ab = c_ab + c_ba for a < b
  for (int a = 0; a < n; ++a) rows[a].tau = tau[a].second;
  for (const auto& p : pairs) {
    int a = local(p.from);
    balance::Row& r = rows[a];
    r.observed = true;
    r.lost = p.effective_samples * (1.0 - p.reflected);
    if (r.lost < 1e-9 * p.effective_samples) r.lost = 0.0;  // rounding of a lossless source
    r.start = r.lambda = p.effective_samples / r.tau;
    for (const auto& [k, fraction] : p.fraction) {
      int b = local(k);
      double c = p.effective_samples * fraction;
      if (a == b)
        r.diag += c;
      else
        counts[{std::min(a, b), std::max(a, b)}] += c;
    }
  }
  for (const auto& [ab, c] : counts) {
    rows[ab.first].partner.emplace_back(ab.second, c);
    rows[ab.second].partner.emplace_back(ab.first, c);
  }
  // Sources that lost no ray demand their rows carry all of tau exactly. Under sampling noise
  // those demands can be jointly impossible for a symmetric matrix of the sampled pattern (two
  // such sources seen only by each other, with different etendues); the ascent then does not
  // settle, and a prior pseudo-count of lost rays for every source makes the problem well posed.
  double mismatch = balance::ascend(rows);
  if (!(mismatch < kBalanceTolerance)) {
    for (auto& r : rows) {
      r.lost += kLostPrior;
      r.lambda = r.start;
    }
    mismatch = balance::ascend(rows);
  }
  for (int a = 0; a < n; ++a) {
    const balance::Row& r = rows[a];
    double sum = balance::row_sum(rows, r, r.lambda).first;
    // Energy: a source's fractions never sum above 1 (all the flux it sends to i).
    double scale = sum > r.tau ? r.tau / sum : 1.0;
    if (r.diag > 0.0)
      out.push_back(
          {tau[a].first, tau[a].first, static_cast<float>(scale * r.diag / r.lambda / r.tau)});
    for (const auto& [b, c] : r.partner) {
      double m = c / (r.lambda + rows[b].lambda);
      if (m > 0.0)
        out.push_back({tau[a].first, tau[b].first, static_cast<float>(scale * m / r.tau)});
    }
  }
  return mismatch;
}

void centre_point_entries(const PatchSet& patches, const Material& m, const FormFactors& ff,
                          PatchId i, std::vector<TransferEntry>& out) {
  // The seed's estimator: rho at patch centres, R_jik = pi f(c_j, c_k) F_ik (from eq. 7 with
  // S_{i->k} = sum_j f pi F_ij L_{j->i}). Zero for a mirror, whose lobe is a delta.
  const Patch& pi = patches[i];
  const Frame frame = Frame::from_normal(pi.normal);
  size_t first = out.size();
  double largest = 0.0;
  for (auto [j, f_ij] : ff.f.row(i)) {
    Vec3 wi = frame.to_local((patches[j].centroid - pi.centroid).normalized());
    for (auto [k, f_ik] : ff.f.row(i)) {
      if (k == j) continue;
      Vec3 wo = frame.to_local((patches[k].centroid - pi.centroid).normalized());
      double r = kPi * m.lobe_eval(wi, wo) * f_ik;
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
                         std::vector<TransferEntry>& out, TransferCounters* counters) {
  TransferCounters local;
  std::vector<TransferEntry> entries;
  if (options.estimator == SpecularEstimator::kCentrePoint) {
    centre_point_entries(patches, material, ff, i, entries);  // symmetric already
  } else {
    std::vector<SampledPair> pairs;
    monte_carlo_pairs(patches, material, ff, caster, options, i, pairs, local);
    if (options.balance) {
      std::vector<std::pair<PatchId, double>> tau;
      for (auto [j, f_ij] : ff.f.row(i)) tau.emplace_back(j, kPi * ff.area[i] * f_ij);
      local.mismatch = balance_reciprocity(pairs, tau, entries);
    } else {
      for (const auto& p : pairs)
        for (const auto& [k, fraction] : p.fraction)
          entries.push_back({p.from, k, static_cast<float>(fraction)});
    }
  }
  // Sorted by (from, to): the order build_transport and the file format expect.
  std::sort(entries.begin(), entries.end(), [](const auto& a, const auto& b) {
    return a.from != b.from ? a.from < b.from : a.to < b.to;
  });
  if (out.empty())
    out.swap(entries);  // no copy: a reflector's entries were faulted in once already
  else
    out.insert(out.end(), entries.begin(), entries.end());
  if (counters) {
    counters->rays += local.rays;
    counters->unseen += local.unseen;
    counters->dropped += local.dropped;
    counters->escaped += local.escaped;
    counters->weight += local.weight;
    counters->mismatch = std::max(counters->mismatch, local.mismatch);
  }
}

SpecularTransfer compute_specular_transfer(const PatchSet& patches,
                                           const std::vector<Material>& materials,
                                           const FormFactors& ff, const RayCaster& caster,
                                           const SpecularOptions& options) {
  const Stopwatch watch;
  const auto n = static_cast<PatchId>(patches.size());
  std::vector<std::vector<TransferEntry>> per_patch(n);
  std::vector<TransferCounters> counters(n);
  long long pairs = 0;
  Progress progress("specular transfer", n);
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : pairs)
  for (PatchId i = 0; i < n; ++i) {
    const Material& m = materials[patches[i].material];
    if (m.has_lobe()) {
      pairs += ff.f.start[i + 1] - ff.f.start[i];
      specular_entries_of(patches, m, ff, caster, options, i, per_patch[i], &counters[i]);
    }
    progress.advance();
  }
  progress.finish();

  SpecularTransfer st;
  st.start.assign(n + 1, 0);
  for (PatchId i = 0; i < n; ++i) st.start[i + 1] = st.start[i] + per_patch[i].size();
  resize_on_huge_pages(st.from, st.start[n]);  // the room's: 7 million entries
  resize_on_huge_pages(st.to, st.start[n]);
  resize_on_huge_pages(st.fraction, st.start[n]);
  TransferCounters total;
  for (PatchId i = 0; i < n; ++i) {
    for (std::size_t k = 0; k < per_patch[i].size(); ++k) {
      const TransferEntry& e = per_patch[i][k];
      st.from[st.start[i] + k] = e.from;
      st.to[st.start[i] + k] = e.to;
      st.fraction[st.start[i] + k] = e.fraction;
    }
    std::vector<TransferEntry>().swap(per_patch[i]);  // held about once
    total.rays += counters[i].rays;
    total.unseen += counters[i].unseen;
    total.dropped += counters[i].dropped;
    total.escaped += counters[i].escaped;
    total.weight += counters[i].weight;
    total.mismatch = std::max(total.mismatch, counters[i].mismatch);
  }
  st.stats.rays = total.rays;
  st.stats.pairs = pairs;
  st.stats.pairs_unseen = total.unseen;
  st.stats.dropped_hits = total.dropped;
  st.stats.balance_mismatch = total.mismatch;
  st.stats.escaped_fraction = total.weight > 0.0 ? total.escaped / total.weight : 0.0;
  st.stats.seconds = watch.seconds();
  return st;
}

}  // namespace polyrad
