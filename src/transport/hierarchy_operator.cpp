// The transport operator on a hierarchy's leaves (hierarchy.h, eq. H2 of
// papers/glossy-radiosity.md): pull means and moments through the trees, gather along the links,
// push the linear functions down and reflect. Kept factored: the trees are two passes over arrays,
// the links one sparse product.
#include <algorithm>
#include <cmath>
#include <functional>

#include "polyrad/transport/hierarchy.h"

namespace polyrad {

namespace {

// The loops over a node's width values carry `omp simd`: GCC does not vectorise them alone (it
// cannot tell the blocks apart), and every value of them is independent of the others.

// Per node, the pulled radiosity as its mean m and first moments q = (1/A') int (y - y_n) B dA
// (y the root parameters, y_n the node's centroid): 3 blocks of width values. Leaves are
// constant (q = 0); a parent adds each child's share of m and of m (y_c - y_p) + q. Reverse
// pre-order, so that a node is complete before it is added to its parent.
void pull_tree(const std::vector<std::int32_t>& parent, const std::vector<float>& share,
               const std::vector<std::array<float, 2>>& centroid,
               const std::vector<std::int32_t>& node_leaf, const std::vector<float>& guard,
               const double* leaf_values, Eigen::Index width, std::int32_t first, std::int32_t last,
               double* b) {
  for (std::int32_t n = first; n < last; ++n) {
    double* y = b + 3 * width * n;
    std::fill(y, y + 3 * width, 0.0);
    const std::int32_t l = node_leaf[n];
    if (l < 0) continue;
    const double* x = leaf_values + width * l;
    const double g = guard[l];
    for (Eigen::Index c = 0; c < width; ++c) y[c] = g * x[c];
  }
  for (std::int32_t n = last - 1; n > first; --n) {
    const std::int32_t p = parent[n];
    if (p < 0) continue;
    const double w = share[n];
    const double du = centroid[n][0] - centroid[p][0], dv = centroid[n][1] - centroid[p][1];
    const double* x = b + 3 * width * n;
    double* y = b + 3 * width * p;
#pragma omp simd  // a child's blocks and its parent's never overlap
    for (Eigen::Index c = 0; c < width; ++c) {
      y[c] += w * x[c];
      y[width + c] += w * (du * x[c] + x[width + c]);
      y[2 * width + c] += w * (dv * x[c] + x[2 * width + c]);
    }
  }
}

// Over the link rows [first, last), per receiving node r: the mean of what it gathers,
// sum F_rs m_s + c_rs . q_s (the source's first moments weighted by the slope of the form factor
// over it), and the slopes of its linear function over r, sum g_rs m_s (eq. H2).
void gather_rows(const Csr<std::array<float, 5>>& links, const double* b, Eigen::Index width,
                 std::int32_t first, std::int32_t last, double* h) {
  for (std::int32_t r = first; r < last; ++r) {
    double* y = h + 3 * width * r;
    std::fill(y, y + 3 * width, 0.0);
    for (auto k = links.start[r]; k < links.start[r + 1]; ++k) {
      const auto& v = links.value[k];
      const double f = v[0], gu = v[1], gv = v[2], cu = v[3], cv = v[4];
      const double* x = b + 3 * width * static_cast<Eigen::Index>(links.column[k]);
#pragma omp simd  // x in b, y in h
      for (Eigen::Index c = 0; c < width; ++c) {
        const double m = x[c];
        y[c] += f * m + cu * x[width + c] + cv * x[2 * width + c];
        y[width + c] += gu * m;
        y[2 * width + c] += gv * m;
      }
    }
  }
}

// The image links' rows [first, last) added to h (eq. H4): as gather_rows, each entry's source
// seen in its mirror plane, so times the plane's colour s_q, and shining with B_s plus the link
// it sends toward the mirror root its path crosses (link_of, with the links' values s; both may
// be null), as receive_specular adds them to the direct links.
void gather_images(const Csr<std::array<float, 5>>& images, const std::vector<std::uint8_t>& plane,
                   const std::vector<Eigen::Array3f>& colour, const std::int32_t* link_of,
                   const double* s, const double* b, Eigen::Index width, int channel,
                   std::int32_t first, std::int32_t last, double* h) {
  if (images.start.empty()) return;
  for (std::int32_t r = first; r < last; ++r) {
    double* y = h + 3 * width * r;
    for (auto k = images.start[r]; k < images.start[r + 1]; ++k) {
      const auto& v = images.value[k];
      const auto& colour_k = colour[plane[k]];
      const double* x = b + 3 * width * static_cast<Eigen::Index>(images.column[k]);
      const std::int32_t l = link_of && s ? link_of[k] : -1;
      const double* sl = l >= 0 ? s + width * static_cast<Eigen::Index>(l) : nullptr;
      for (Eigen::Index c = 0; c < width; ++c) {
        const double t = channel >= 0 ? colour_k[channel] : colour_k[c % 3];
        const double m = t * (sl ? x[c] + sl[c] : x[c]);
        y[c] += v[0] * m + t * (v[3] * x[width + c] + v[4] * x[2 * width + c]);
        y[width + c] += v[1] * m;
        y[2 * width + c] += v[2] * m;
      }
    }
  }
}

// Children take their ancestors' linear functions at their own centroids (pre-order: the parent
// is complete first); the slopes pass on unchanged, as they are in the root's parameters.
void push_tree(const std::vector<std::int32_t>& parent,
               const std::vector<std::array<float, 2>>& centroid, Eigen::Index width,
               std::int32_t first, std::int32_t last, double* h) {
  for (std::int32_t n = first + 1; n < last; ++n) {
    const std::int32_t p = parent[n];
    if (p < 0) continue;
    const double du = centroid[n][0] - centroid[p][0], dv = centroid[n][1] - centroid[p][1];
    const double* x = h + 3 * width * p;
    double* y = h + 3 * width * n;
#pragma omp simd  // a parent's blocks and its child's never overlap
    for (Eigen::Index c = 0; c < width; ++c) {
      y[c] += x[c] + du * x[width + c] + dv * x[2 * width + c];
      y[width + c] += x[width + c];
      y[2 * width + c] += x[2 * width + c];
    }
  }
}

}  // namespace

std::size_t RootSpecular::bytes() const {
  return links.size() * sizeof(Link) + link_start.size() * sizeof(std::int64_t) +
         flux_weight.size() * sizeof(double) + colour.size() * sizeof(Eigen::Array3f) +
         reflector.size() * sizeof(std::int32_t) + pair_start.size() * sizeof(std::int64_t) +
         pair_source.size() * sizeof(std::int32_t) + pair_f.size() * sizeof(float) +
         pair_link.size() * sizeof(std::int64_t) + pair_reflected.size() * sizeof(float) +
         links_only.size() + image_link.size() * sizeof(std::int32_t) +
         entry_start.size() * sizeof(std::int64_t) + entry_pair.size() * sizeof(std::int32_t) +
         rows.bytes() + receive_start.size() * sizeof(std::int64_t) +
         receive_entry.size() * sizeof(std::int32_t);
}

void HierarchicalOperator::receive_specular(const double* s, Eigen::Index width,
                                            std::int32_t first_tree, std::int32_t last_tree,
                                            double* h) const {
  // Eq. H3 (a): along each link r <- s from a reflector's tree, the radiance leaving s toward r
  // has the specular part S_{root(s)->root(r)} too; it is constant over s (no moments).
  const RootSpecular& sp = *specular_;
  for (std::int32_t k = first_tree; k < last_tree; ++k) {
    if (sp.receive_start[k] < 0) continue;
    const std::int32_t* link_of = sp.receive_entry.data() + sp.receive_start[k];
    const std::int32_t first = tree_start_[k], last = tree_start_[k + 1];
    const std::int64_t e0 = links_.start[first];
    for (std::int32_t r = first; r < last; ++r) {
      double* y = h + 3 * width * r;
      for (auto e = links_.start[r]; e < links_.start[r + 1]; ++e) {
        const std::int32_t l = link_of[e - e0];
        if (l < 0) continue;
        const auto& v = links_.value[e];
        const double* x = s + width * static_cast<Eigen::Index>(l);
        for (Eigen::Index c = 0; c < width; ++c) {
          y[c] += v[0] * x[c];
          y[width + c] += v[1] * x[c];
          y[2 * width + c] += v[2] * x[c];
        }
      }
    }
  }
}

void HierarchicalOperator::specular_rows(std::int64_t x, const double* b, const double* s,
                                         Eigen::Index width, int channel, double* lin,
                                         double* out) const {
  // Eq. H3 (b): what arrives at reflector i from each root j along its tree's links (the mean
  // part of each link's gather, weighed by the receiving node's share of i), plus the root link
  // S_{j->i}; then S_{i->k} = s_i sum_j (R_jik / F_ik) of those.
  const RootSpecular& sp = *specular_;
  const std::int32_t i = sp.reflector[x];
  const std::int64_t p0 = sp.pair_start[x], pairs = sp.pair_start[x + 1] - p0;
  std::fill(lin, lin + pairs * width, 0.0);
  const std::int32_t first = tree_start_[i], last = tree_start_[i + 1];
  const double area = exposed_[first];
  const std::int64_t e0 = links_.start[first];
  const std::int32_t* pair_of = sp.entry_pair.data() + sp.entry_start[x];
  if (area > 0.0) {
    for (std::int32_t r = first; r < last; ++r) {
      const double w = exposed_[r] / area;
      if (!(w > 0.0)) continue;
      for (auto e = links_.start[r]; e < links_.start[r + 1]; ++e) {
        const std::int32_t q = pair_of[e - e0];
        if (q < 0) continue;  // a source whose root form factor rounded to 0
        const auto& v = links_.value[e];
        const double f = w * v[0], cu = w * v[3], cv = w * v[4];
        const double* m = b + 3 * width * static_cast<Eigen::Index>(links_.column[e]);
        double* y = lin + width * q;
        for (Eigen::Index c = 0; c < width; ++c)
          y[c] += f * m[c] + cu * m[width + c] + cv * m[2 * width + c];
      }
    }
  }
  for (std::int64_t q = 0; q < pairs; ++q) {
    const std::int64_t l = sp.pair_link[p0 + q];
    if (l < 0) continue;
    const double f = sp.pair_f[p0 + q];
    const double* v = s + width * l;
    double* y = lin + width * q;
    for (Eigen::Index c = 0; c < width; ++c) y[c] += f * v[c];
  }
  for (auto l = sp.link_start[i]; l < sp.link_start[i + 1]; ++l) {
    double* y = out + width * (l - sp.link_start[i]);
    std::fill(y, y + width, 0.0);
    if (sp.links_only[l]) continue;  // the image links stand for it (eq. H4)
    sp.rows.accumulate_row(l, lin, width, y);
    const auto& colour = sp.colour[l];
    if (channel >= 0) {
      y[0] *= colour[channel];
    } else {
      for (Eigen::Index c = 0; c < width; ++c) y[c] *= colour[c % 3];
    }
  }
}

// The operator's node buffers while free, else buffers of this call's own; either way `size`
// doubles each, not cleared: every entry is written before it is read (pull_tree fills each
// node of its tree, gather_rows each row, and apply and the sweep run both over every node).
// Clearing them wrote 2 x 190 MB more, on one thread, at each application of the room's
// hierarchical precompute (23 columns), though paired runs did not tell the difference.
class HierarchicalOperator::BorrowedBuffers {
 public:
  BorrowedBuffers(const HierarchicalOperator& op, std::size_t size)
      : lock_(op.buffers_mutex_, std::try_to_lock), buffers_(lock_ ? op.buffers_ : own_) {
    buffers_.b.resize(size);
    buffers_.h.resize(size);
  }
  std::vector<double>& b() { return buffers_.b; }
  std::vector<double>& h() { return buffers_.h; }

 private:
  std::unique_lock<std::mutex> lock_;
  NodeBuffers own_;
  NodeBuffers& buffers_;
};

void HierarchicalOperator::pull_all(const double* in, Eigen::Index width, double* b) const {
  const auto trees = static_cast<std::int32_t>(tree_start_.size()) - 1;
#pragma omp parallel for schedule(dynamic, 16)
  for (std::int32_t k = 0; k < trees; ++k)
    pull_tree(parent_, share_, centroid_, node_leaf_, guard_, in, width, tree_start_[k],
              tree_start_[k + 1], b);
}

void HierarchicalOperator::apply(const double* in, double* out, Eigen::Index width,
                                 int channel) const {
  const auto trees = static_cast<std::int32_t>(tree_start_.size()) - 1;
  const auto n = static_cast<std::int32_t>(nodes());
  BorrowedBuffers buffers(*this, 3 * static_cast<std::size_t>(n) * width);
  std::vector<double>& b = buffers.b();
  std::vector<double>& h = buffers.h();
  pull_all(in, width, b.data());
  constexpr std::int32_t kRows = 256;
#pragma omp parallel for schedule(dynamic, 1)
  for (std::int32_t r0 = 0; r0 < n; r0 += kRows) {
    gather_rows(links_, b.data(), width, r0, std::min(n, r0 + kRows), h.data());
    gather_images(images_, image_plane_, plane_colour_, image_entry_links(), in + width * leaves(),
                  b.data(), width, channel, r0, std::min(n, r0 + kRows), h.data());
  }
  const auto leaves_count = static_cast<std::int32_t>(leaves());
  const double* s = in + width * leaves_count;  // the specular links, after the leaves
  // Links that carry nothing (T applied to an emission: the mesh's direct light, a series' first
  // term) add nothing; skipped, since their scattered reads cost the room's hierarchy 0.4 s a call.
  if (specular_ &&
      std::any_of(s, s + width * specular_->num_links(), [](double v) { return v != 0.0; })) {
#pragma omp parallel for schedule(dynamic, 16)
    for (std::int32_t k = 0; k < trees; ++k) receive_specular(s, width, k, k + 1, h.data());
  }
#pragma omp parallel for schedule(dynamic, 16)
  for (std::int32_t k = 0; k < trees; ++k)
    push_tree(parent_, centroid_, width, tree_start_[k], tree_start_[k + 1], h.data());
#pragma omp parallel for schedule(static)
  for (std::int32_t l = 0; l < leaves_count; ++l) {
    const double* x = h.data() + 3 * width * leaf_node_[l];  // the mean at the leaf
    double* y = out + width * l;
    const auto& rho = rho_[l];
    if (channel >= 0) {
      y[0] = rho[channel] * x[0];
    } else {
      for (Eigen::Index c = 0; c < width; ++c) y[c] = rho[c % 3] * x[c];
    }
  }
  if (!specular_) return;
  const auto reflectors = static_cast<std::int64_t>(specular_->reflector.size());
#pragma omp parallel
  {
    std::vector<double> lin(static_cast<std::size_t>(specular_->max_pairs * width));
#pragma omp for schedule(dynamic, 1)
    for (std::int64_t x = 0; x < reflectors; ++x)
      specular_rows(x, b.data(), s, width, channel, lin.data(),
                    out + width * (leaves_count + specular_->link_start[specular_->reflector[x]]));
  }
}

void HierarchicalOperator::apply_images(const double* in, double* out, Eigen::Index width) const {
  const auto trees = static_cast<std::int32_t>(tree_start_.size()) - 1;
  const auto n = static_cast<std::int32_t>(nodes());
  const auto leaves_count = static_cast<std::int32_t>(leaves());
  BorrowedBuffers buffers(*this, 3 * static_cast<std::size_t>(n) * width);
  std::vector<double>& b = buffers.b();
  std::vector<double>& h = buffers.h();
  pull_all(in, width, b.data());
#pragma omp parallel for schedule(dynamic, 16)
  for (std::int32_t k = 0; k < trees; ++k) {
    std::fill(h.data() + 3 * width * tree_start_[k], h.data() + 3 * width * tree_start_[k + 1],
              0.0);
    gather_images(images_, image_plane_, plane_colour_, image_entry_links(),
                  in + width * leaves_count, b.data(), width, -1, tree_start_[k],
                  tree_start_[k + 1], h.data());
    push_tree(parent_, centroid_, width, tree_start_[k], tree_start_[k + 1], h.data());
  }
#pragma omp parallel for schedule(static)
  for (std::int32_t l = 0; l < leaves_count; ++l) {
    const double* x = h.data() + 3 * width * leaf_node_[l];
    for (Eigen::Index c = 0; c < width; ++c) out[width * l + c] = rho_[l][c % 3] * x[c];
  }
}

namespace {

// Consecutive runs of [0, count) whose weights sum to about total / kSweepWaves (a run holds at
// least one item): the waves of a sweep. They depend on the operator alone, not on the threads,
// so a solve gives the same numbers on any thread count.
constexpr std::int64_t kSweepWaves = 16;
std::vector<std::int32_t> waves(std::int32_t count,
                                const std::function<std::int64_t(std::int32_t)>& weight) {
  std::int64_t total = 0;
  for (std::int32_t k = 0; k < count; ++k) total += weight(k);
  const std::int64_t target = std::max<std::int64_t>(1, total / kSweepWaves);
  std::vector<std::int32_t> start{0};
  std::int64_t sum = 0;
  for (std::int32_t k = 0; k < count; ++k) {
    sum += weight(k);
    if (sum >= target && k + 1 < count) {
      start.push_back(k + 1);
      sum = 0;
    }
  }
  start.push_back(count);
  return start;
}

}  // namespace

void HierarchicalOperator::gauss_seidel_sweep(const Field& e, Field& u) const {
  const Eigen::Index width = 3;
  BorrowedBuffers buffers(*this, 3 * static_cast<std::size_t>(nodes()) * width);
  double* b = buffers.b().data();
  double* h = buffers.h().data();
  const auto trees = static_cast<std::int32_t>(tree_start_.size()) - 1;
  const std::vector<std::int32_t> wave = waves(trees, [&](std::int32_t k) {
    return links_.start[tree_start_[k + 1]] - links_.start[tree_start_[k]] + 1;
  });
#pragma omp parallel
  {
#pragma omp for schedule(dynamic, 16)
    for (std::int32_t k = 0; k < trees; ++k)
      pull_tree(parent_, share_, centroid_, node_leaf_, guard_, u.data(), width, tree_start_[k],
                tree_start_[k + 1], b);
    for (std::size_t w = 0; w + 1 < wave.size(); ++w) sweep_wave(wave[w], wave[w + 1], e, u, b, h);
  }
  if (specular_) sweep_reflectors(e, u, b);
}

// Trees [first, last) of a sweep, inside its parallel region: each gathers from the values
// every tree had when the wave began (no direct link joins a tree to itself; an image link that
// does reads the tree as the wave found it), pushes and reflects; only then do they pull their
// new values.
void HierarchicalOperator::sweep_wave(std::int32_t first, std::int32_t last, const Field& e,
                                      Field& u, double* b, double* h) const {
  const Eigen::Index width = 3;
  const double* s = u.data() + width * leaves();  // the specular links, after the leaves
#pragma omp for schedule(dynamic, 1)
  for (std::int32_t k = first; k < last; ++k) {
    const std::int32_t n0 = tree_start_[k], n1 = tree_start_[k + 1];
    gather_rows(links_, b, width, n0, n1, h);
    gather_images(images_, image_plane_, plane_colour_, image_entry_links(), s, b, width, -1, n0,
                  n1, h);
    if (specular_) receive_specular(s, width, k, k + 1, h);
    push_tree(parent_, centroid_, width, n0, n1, h);
    for (std::int32_t m = n0; m < n1; ++m) {
      const std::int32_t l = node_leaf_[m];
      if (l < 0) continue;
      for (int c = 0; c < 3; ++c) u(l, c) = e(l, c) + rho_[l][c] * h[3 * width * m + c];
    }
  }
#pragma omp for schedule(dynamic, 1)
  for (std::int32_t k = first; k < last; ++k)
    pull_tree(parent_, share_, centroid_, node_leaf_, guard_, u.data(), width, tree_start_[k],
              tree_start_[k + 1], b);
}

// The reflectors' link rows, wave by wave like the trees: a wave's rows read the links as the
// wave found them (a row of reflector i never reads i's own links: S_{j->i} has j != i), into
// `row`, and are written after.
void HierarchicalOperator::sweep_reflectors(const Field& e, Field& u, const double* b) const {
  const Eigen::Index width = 3;
  const Eigen::Index leaves_count = leaves();
  double* s = u.data() + width * leaves_count;
  const RootSpecular& sp = *specular_;
  const auto reflectors = static_cast<std::int32_t>(sp.reflector.size());
  auto first_link = [&](std::int32_t x) { return sp.link_start[sp.reflector[x]]; };
  auto end_link = [&](std::int32_t x) { return sp.link_start[sp.reflector[x] + 1]; };
  const std::vector<std::int32_t> wave = waves(reflectors, [&](std::int32_t x) {
    return sp.rows.start[end_link(x)] - sp.rows.start[first_link(x)] + 1;
  });
  std::vector<std::int64_t> row_at(reflectors, 0);  // each reflector's first link in `row`
  std::int64_t most = 0;
  for (std::size_t w = 0; w + 1 < wave.size(); ++w) {
    std::int64_t at = 0;
    for (std::int32_t x = wave[w]; x < wave[w + 1]; ++x) {
      row_at[x] = at;
      at += end_link(x) - first_link(x);
    }
    most = std::max(most, at);
  }
  std::vector<double> row(static_cast<std::size_t>(most * width));
#pragma omp parallel
  {
    std::vector<double> lin(static_cast<std::size_t>(sp.max_pairs * width));
    for (std::size_t w = 0; w + 1 < wave.size(); ++w) {
#pragma omp for schedule(dynamic, 1)
      for (std::int32_t x = wave[w]; x < wave[w + 1]; ++x)
        specular_rows(x, b, s, width, -1, lin.data(), row.data() + width * row_at[x]);
#pragma omp for schedule(dynamic, 1)
      for (std::int32_t x = wave[w]; x < wave[w + 1]; ++x)
        for (std::int64_t l = first_link(x); l < end_link(x); ++l)
          for (Eigen::Index c = 0; c < width; ++c)
            s[width * l + c] =
                e(leaves_count + l, c) + row[width * (row_at[x] + l - first_link(x)) + c];
    }
  }
}

Eigen::Array3d HierarchicalOperator::entry_albedo(std::int32_t t, std::int64_t entry,
                                                  const Eigen::Array3d& rho_t) const {
  if (!specular_) return rho_t;
  const RootSpecular& sp = *specular_;
  const auto it = std::lower_bound(sp.reflector.begin(), sp.reflector.end(), t);
  if (it == sp.reflector.end() || *it != t) return rho_t;
  const auto x = static_cast<std::int64_t>(it - sp.reflector.begin());
  const std::int64_t q = sp.entry_pair[sp.entry_start[x] + entry - links_.start[tree_start_[t]]];
  if (q < 0) return rho_t;
  return rho_t +
         sp.colour[sp.link_start[t]].cast<double>() * sp.pair_reflected[sp.pair_start[x] + q];
}

std::vector<double> HierarchicalOperator::column_sums(bool with_guard, bool reflectance) const {
  // A reflector's receiving nodes count d + s sum_k R_jik per source root j (eq. H3 (b)).
  const std::vector<Eigen::Array3d> rho = tree_reflectance();
  std::vector<double> sums = column_sums_by(
      [&](std::int32_t t, std::int64_t entry) {
        if (!reflectance) return Eigen::Array3d(Eigen::Array3d::Ones());
        return entry_albedo(t, entry, rho[t]);
      },
      reflectance);
  if (with_guard)
    for (std::size_t l = 0; l < sums.size(); ++l) sums[l] *= guard_[l];
  return sums;
}

std::vector<Eigen::Array3d> HierarchicalOperator::tree_reflectance() const {
  // A tree is one patch, one material: the reflectance of any of its leaves.
  const auto trees = static_cast<std::int32_t>(tree_start_.size()) - 1;
  std::vector<Eigen::Array3d> rho(trees, Eigen::Array3d::Zero());
  for (std::int32_t t = 0; t < trees; ++t)
    for (std::int32_t m = tree_start_[t]; m < tree_start_[t + 1]; ++m)
      if (node_leaf_[m] >= 0) {
        rho[t] = rho_[node_leaf_[m]].cast<double>();
        break;
      }
  return rho;
}

std::vector<double> HierarchicalOperator::column_sums_by(
    const std::function<Eigen::Array3d(std::int32_t, std::int64_t)>& albedo, bool images) const {
  // The flux a unit of flux at leaf l sends along link r <- s, s above l (l included), is
  // rho_r (F_sr + g_sr . (y_l - y_s)) with g_sr = (A'_s / A'_r) c_rs: per node s, the sums
  // K_s = sum rho_r A'_r F_rs / A'_s and their slopes, then for each leaf the chain of its nodes.
  const auto n = static_cast<std::int32_t>(nodes());
  const auto trees = static_cast<std::int32_t>(tree_start_.size()) - 1;
  std::vector<Eigen::Array3d> k(n, Eigen::Array3d::Zero()), ku(n, Eigen::Array3d::Zero()),
      kv(n, Eigen::Array3d::Zero());
  for (std::int32_t t = 0; t < trees; ++t) {
    for (std::int32_t r = tree_start_[t]; r < tree_start_[t + 1]; ++r) {
      for (auto e = links_.start[r]; e < links_.start[r + 1]; ++e) {
        const std::int32_t s = links_.column[e];
        if (!(exposed_[s] > 0.0)) continue;
        const Eigen::Array3d a = albedo(t, e);
        const double w = exposed_[r] / exposed_[s];
        k[s] += a * (w * links_.value[e][0]);
        ku[s] += a * (w * links_.value[e][3]);
        kv[s] += a * (w * links_.value[e][4]);
      }
    }
  }
  // The image links (eq. H4), each weighed by its receiver's reflectance and its plane's colour.
  if (images && !images_.start.empty()) {
    const std::vector<Eigen::Array3d> rho = tree_reflectance();
    for (std::int32_t t = 0; t < trees; ++t)
      for (std::int32_t r = tree_start_[t]; r < tree_start_[t + 1]; ++r)
        for (auto e = images_.start[r]; e < images_.start[r + 1]; ++e) {
          const std::int32_t s = images_.column[e];
          if (!(exposed_[s] > 0.0)) continue;
          const Eigen::Array3d a = rho[t] * plane_colour_[image_plane_[e]].cast<double>();
          const double w = exposed_[r] / exposed_[s];
          k[s] += a * (w * images_.value[e][0]);
          ku[s] += a * (w * images_.value[e][3]);
          kv[s] += a * (w * images_.value[e][4]);
        }
  }
  std::vector<double> sums(leaves());
  for (std::int32_t l = 0; l < static_cast<std::int32_t>(leaves()); ++l) {
    const std::int32_t leaf = leaf_node_[l];
    Eigen::Array3d sum = Eigen::Array3d::Zero();
    for (std::int32_t s = leaf; s >= 0; s = parent_[s])
      sum += k[s] + ku[s] * (centroid_[leaf][0] - centroid_[s][0]) +
             kv[s] * (centroid_[leaf][1] - centroid_[s][1]);
    sums[l] = sum.maxCoeff();
  }
  return sums;
}

std::size_t HierarchicalOperator::bytes() const {
  return links_.bytes() + images_.bytes() + image_plane_.size() +
         image_root_.size() * sizeof(std::int32_t) + parent_.size() * sizeof(std::int32_t) +
         share_.size() * sizeof(float) + node_leaf_.size() * sizeof(std::int32_t) +
         leaf_node_.size() * sizeof(std::int32_t) + tree_start_.size() * sizeof(std::int32_t) +
         rho_.size() * sizeof(Eigen::Array3f) + guard_.size() * sizeof(float) +
         exposed_.size() * sizeof(double) + centroid_.size() * sizeof(centroid_[0]) +
         (specular_ ? specular_->bytes() : 0);
}

}  // namespace polyrad
