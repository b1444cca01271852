// Reverse Cuthill-McKee ordering and bandwidth (reorder.h).
#include "polyrad/transport/reorder.h"

#include <algorithm>
#include <cstdlib>
#include <numeric>
#include <stdexcept>
#include <string>

#include "polyrad/util/error.h"

namespace polyrad {

namespace {

// An undirected graph in adjacency lists: the neighbours of v are next[start[v], start[v+1]).
struct Graph {
  std::vector<std::int64_t> start;
  std::vector<std::int32_t> next;

  std::int32_t nodes() const { return static_cast<std::int32_t>(start.size()) - 1; }
  std::int64_t degree(std::int32_t v) const { return start[v + 1] - start[v]; }
};

// Ascending degree, then ascending index: the one tie-break used everywhere, so that the order
// depends on the pattern alone.
struct ByDegree {
  const Graph* g;
  bool operator()(std::int32_t a, std::int32_t b) const {
    const auto da = g->degree(a), db = g->degree(b);
    return da != db ? da < db : a < b;
  }
};

// The symmetrised pattern of m without its diagonal or duplicate neighbours. Linear in nnz(m):
// T's diffuse rows are nearly dense over the patches, so a sort per list would cost more than
// the rest of the ordering together.
Graph symmetric_pattern(const Csr<float>& m) {
  POLYRAD_CHECK(m.rows == m.cols);
  const auto n = static_cast<std::int32_t>(m.rows);
  std::vector<std::int64_t> count(n + 1, 0);
  for (std::int32_t r = 0; r < n; ++r)
    for (auto [c, value] : m.row(r))
      if (c != r) {
        ++count[r + 1];
        ++count[c + 1];
      }
  std::partial_sum(count.begin(), count.end(), count.begin());
  std::vector<std::int32_t> next(count[n]);
  std::vector<std::int64_t> fill(count.begin(), count.end() - 1);
  for (std::int32_t r = 0; r < n; ++r)
    for (auto [c, value] : m.row(r))
      if (c != r) {
        next[fill[r]++] = c;
        next[fill[c]++] = r;
      }
  // Remove duplicates (an entry and its transpose), compacting in place: seen[w] == v marks a
  // neighbour of v already kept.
  Graph g;
  g.start.assign(n + 1, 0);
  std::vector<std::int32_t> seen(n, -1);
  std::int64_t kept = 0;
  for (std::int32_t v = 0; v < n; ++v) {
    for (auto k = count[v]; k < count[v + 1]; ++k)
      if (const std::int32_t w = next[k]; seen[w] != v) {
        seen[w] = v;
        next[kept++] = w;
      }
    g.start[v + 1] = kept;
  }
  next.resize(kept);
  g.next = std::move(next);
  return g;
}

// Breadth-first search of root's component: appends its nodes to `visit` in the order reached,
// each node's newly reached neighbours by ascending degree (Cuthill-McKee's order), and returns
// the number of levels. `level` must be -1 on the whole component; the caller resets it.
int breadth_first(const Graph& g, std::int32_t root, std::vector<int>& level,
                  std::vector<std::int32_t>& visit) {
  const std::size_t begin = visit.size();
  visit.push_back(root);
  level[root] = 0;
  int depth = 0;
  for (std::size_t head = begin; head < visit.size(); ++head) {
    const std::int32_t v = visit[head];
    depth = level[v];
    const std::size_t children = visit.size();
    for (auto k = g.start[v]; k < g.start[v + 1]; ++k) {
      const std::int32_t w = g.next[k];
      if (level[w] >= 0) continue;
      level[w] = level[v] + 1;
      visit.push_back(w);
    }
    std::sort(visit.begin() + static_cast<std::ptrdiff_t>(children), visit.end(), ByDegree{&g});
  }
  return depth + 1;
}

// George and Liu's pseudo-peripheral node: from `start`, move to the least-degree node of the
// last level while that lengthens the level structure (a node far from everything starts a
// narrow band, whose levels are many and small). Returns the last node tried: as far from its
// predecessor as any node is. The last level of a search is the tail of its visit list.
std::int32_t pseudo_peripheral(const Graph& g, std::int32_t start, std::vector<int>& level,
                               std::vector<std::int32_t>& visit) {
  std::int32_t root = start;
  int depth = -1;
  for (;;) {
    visit.clear();
    const int d = breadth_first(g, root, level, visit);
    const int last = level[visit.back()];
    std::int32_t candidate = visit.back();
    for (auto it = visit.rbegin(); it != visit.rend() && level[*it] == last; ++it)
      if (ByDegree{&g}(*it, candidate)) candidate = *it;
    for (std::int32_t v : visit) level[v] = -1;
    if (d <= depth) return root;
    depth = d;
    if (candidate == root) return root;
    root = candidate;
  }
}

}  // namespace

Permutation Permutation::from_order(std::vector<std::int32_t> order) {
  Permutation p;
  p.position.assign(order.size(), -1);
  for (std::size_t n = 0; n < order.size(); ++n) {
    const std::int32_t old = order[n];
    if (old < 0 || static_cast<std::size_t>(old) >= order.size() || p.position[old] >= 0)
      throw std::invalid_argument("not a permutation: index " + std::to_string(old) + " at " +
                                  std::to_string(n));
    p.position[old] = static_cast<std::int32_t>(n);
  }
  p.order = std::move(order);
  return p;
}

Permutation reverse_cuthill_mckee(const Csr<float>& m) {
  const Graph g = symmetric_pattern(m);
  const std::int32_t n = g.nodes();
  // Components are started in ascending degree: the first node not yet placed is then the
  // least-degree node of its component.
  std::vector<std::int32_t> by_degree(n);
  std::iota(by_degree.begin(), by_degree.end(), 0);
  std::sort(by_degree.begin(), by_degree.end(), ByDegree{&g});
  std::vector<char> placed(n, 0);
  std::vector<int> level(n, -1);
  std::vector<std::int32_t> order, scratch;
  order.reserve(n);
  for (std::int32_t start : by_degree) {
    if (placed[start]) continue;
    const std::int32_t root = pseudo_peripheral(g, start, level, scratch);
    const std::size_t first = order.size();
    breadth_first(g, root, level, order);
    for (std::size_t k = first; k < order.size(); ++k) {
      placed[order[k]] = 1;
      level[order[k]] = -1;
    }
  }
  std::reverse(order.begin(), order.end());
  return Permutation::from_order(std::move(order));
}

namespace {

// max |number(row) - number(column)| over m's stored entries.
template <typename Number>
std::int64_t band(const Csr<float>& m, Number number) {
  std::int64_t b = 0;
  for (std::int64_t r = 0; r < m.rows; ++r)
    for (auto [c, value] : m.row(r)) b = std::max<std::int64_t>(b, std::abs(number(r) - number(c)));
  return b;
}

}  // namespace

std::int64_t bandwidth(const Csr<float>& m) {
  return band(m, [](std::int64_t i) { return i; });
}

std::int64_t bandwidth(const Csr<float>& m, const Permutation& p) {
  POLYRAD_CHECK(p.size() == m.rows && m.rows == m.cols);
  return band(m, [&](std::int64_t i) { return static_cast<std::int64_t>(p.position[i]); });
}

}  // namespace polyrad
