// The specular part of the hierarchical mesh (hierarchy.h, RootSpecular; eq. H3 and section 12.6
// of papers/glossy-radiosity.md): root form factors from the links, the root links and their
// rows, and the two couplings with the leaves.
#include <algorithm>
#include <tuple>

#include "polyrad/transport/hierarchy.h"
#include "polyrad/util/machine.h"

namespace polyrad {

FormFactors root_form_factors(const ElementHierarchy& h, const std::vector<Material>& materials,
                              const std::function<void(const LinkVisitor&)>& for_each_link) {
  const std::vector<Element>& el = h.elements();
  const PatchSet& roots = h.roots();
  const auto count = static_cast<std::int32_t>(h.num_roots());
  std::vector<char> lobe(count, 0);
  for (std::int32_t r = 0; r < count; ++r) lobe[r] = materials[roots[r].material].has_lobe();
  // G_ij = sum of A'_a F_ab over the links between the trees of i and j (eq. 4, the etendue
  // over pi): the finer the links, the finer the pair integral they sum to.
  std::vector<std::tuple<std::int32_t, std::int32_t, double>> g;
  for_each_link([&](const LinkedPair& l) {
    const std::int32_t ra = el[l.a].root, rb = el[l.b].root;
    const double etendue = el[l.a].exposed * static_cast<double>(l.m);
    if (!(etendue > 0.0)) return;
    if (lobe[ra]) g.emplace_back(ra, rb, etendue);
    if (lobe[rb]) g.emplace_back(rb, ra, etendue);
  });
  std::sort(g.begin(), g.end());
  FormFactors ff;
  ff.area.resize(count);
  for (std::int32_t r = 0; r < count; ++r) ff.area[r] = el[r].exposed;
  ff.f.cols = count;
  std::size_t k = 0;
  for (std::int32_t i = 0; i < count; ++i) {
    while (k < g.size() && std::get<0>(g[k]) == i) {
      const std::int32_t j = std::get<1>(g[k]);
      double sum = 0.0;
      for (; k < g.size() && std::get<0>(g[k]) == i && std::get<1>(g[k]) == j; ++k)
        sum += std::get<2>(g[k]);
      const auto f = static_cast<float>(ff.area[i] > 0.0 ? sum / ff.area[i] : 0.0);
      if (!(f > 0.0f)) continue;
      ff.f.column.push_back(j);
      ff.f.value.push_back(f);
    }
    ff.f.push_row();
  }
  return ff;
}

namespace {

// The index of link (i -> k) in links of root i, or -1.
std::int64_t find_link(const RootSpecular& sp, PatchId i, PatchId k) {
  const auto first = sp.links.begin() + sp.link_start[i];
  const auto last = sp.links.begin() + sp.link_start[i + 1];
  const auto it =
      std::lower_bound(first, last, k, [](const Link& l, PatchId key) { return l.to < key; });
  return it != last && it->to == k ? it - sp.links.begin() : -1;
}

// The local index of source j among reflector x's pairs, or -1.
std::int32_t find_pair(const RootSpecular& sp, std::int64_t x, std::int32_t j) {
  const auto first = sp.pair_source.begin() + sp.pair_start[x];
  const auto last = sp.pair_source.begin() + sp.pair_start[x + 1];
  const auto it = std::lower_bound(first, last, j);
  return it != last && *it == j ? static_cast<std::int32_t>(it - first) : -1;
}

// The operator's trees and link rows, as the couplings read them.
struct TreeRows {
  const std::vector<std::int32_t>& tree_start;   // nodes of tree k
  const std::vector<std::int64_t>& entry_start;  // link entries of node n
  const std::vector<std::int32_t>& column;       // each entry's source node

  std::int64_t first_entry(std::int32_t tree) const { return entry_start[tree_start[tree]]; }
  std::int64_t end_entry(std::int32_t tree) const { return entry_start[tree_start[tree + 1]]; }
  // The tree (root) of a node: trees are consecutive runs of nodes.
  std::int32_t root_of(std::int32_t node) const {
    return static_cast<std::int32_t>(std::upper_bound(tree_start.begin(), tree_start.end(), node) -
                                     tree_start.begin() - 1);
  }
};

// The links (section 3's fixed point on the roots), their flux weights tau_ik and colours.
void add_links(RootSpecular& sp, const PatchSet& roots, const std::vector<Material>& materials,
               const FormFactors& ff, const SpecularTransfer& transfer) {
  const auto count = static_cast<std::int32_t>(roots.size());
  sp.links = active_specular_links(roots, materials, ff, transfer);
  sp.link_start.assign(count + 1, 0);
  for (const Link& l : sp.links) ++sp.link_start[l.from + 1];
  for (std::int32_t r = 0; r < count; ++r) sp.link_start[r + 1] += sp.link_start[r];
  for (const Link& l : sp.links) {
    sp.flux_weight.push_back(kPi * ff.area[l.from] * ff.at(l.from, l.to));
    sp.colour.push_back(materials[roots[l.from].material].specular.cast<float>());
  }
}

// Eq. H4: a planar mirror's link toward a root without a lobe carries only what the mirror's
// links bring it where image links carry its leaves' light.
void mark_links_only(RootSpecular& sp, const PatchSet& roots,
                     const std::vector<Material>& materials, const MirrorPlanes& mirrors) {
  sp.links_only.assign(sp.links.size(), 0);
  if (mirrors.empty()) return;
  for (std::size_t l = 0; l < sp.links.size(); ++l)
    sp.links_only[l] = mirrors.plane_of[sp.links[l].from] >= 0 &&
                       !materials[roots[sp.links[l].to].material].has_lobe();
}

// The reflectors with links and their pairs (row i of the root form factors).
void add_pairs(RootSpecular& sp, const FormFactors& ff) {
  const auto count = static_cast<std::int32_t>(sp.link_start.size()) - 1;
  for (std::int32_t i = 0; i < count; ++i)
    if (sp.link_start[i + 1] > sp.link_start[i]) sp.reflector.push_back(i);
  sp.pair_start.push_back(0);
  for (std::size_t x = 0; x < sp.reflector.size(); ++x) {
    for (auto [j, f] : ff.f.row(sp.reflector[x])) {
      sp.pair_source.push_back(j);
      sp.pair_f.push_back(f);
    }
    sp.pair_start.push_back(static_cast<std::int64_t>(sp.pair_source.size()));
    sp.max_pairs = std::max(sp.max_pairs, sp.pair_start[x + 1] - sp.pair_start[x]);
  }
  sp.pair_link.resize(sp.pair_source.size());
  sp.pair_reflected.assign(sp.pair_source.size(), 0.0f);
#pragma omp parallel for schedule(dynamic, 16)
  for (std::int64_t x = 0; x < static_cast<std::int64_t>(sp.reflector.size()); ++x)
    for (auto q = sp.pair_start[x]; q < sp.pair_start[x + 1]; ++q)
      sp.pair_link[q] = find_link(sp, sp.pair_source[q], sp.reflector[x]);
}

// A thread's slots, indexed by root, and its rows (kept for their capacity).
struct RowScratch {
  explicit RowScratch(std::size_t roots) : link_of(roots, -1), pair_of(roots, -1), f_to(roots) {}
  std::vector<std::int64_t> link_of;
  std::vector<std::int32_t> pair_of;
  std::vector<double> f_to;
  std::vector<std::vector<std::pair<std::int32_t, double>>> rows;
};

// The rows of reflector x, eq. H3 (b): S_{i->k} reads pair (i, j) with weight R_jik / F_ik; and
// the pairs' reflected sums. Its links, pairs and form factors in slots indexed by root (no
// search per transfer entry: the room has 7 million, the rows took 1.2 s with searches); the
// slots are the calling thread's and are left as they were found (-1, -1, 0). The entries go to
// sp.rows from `at` on, each row's length to its start[l + 1]; returns how many were written.
std::int64_t reflector_rows(RootSpecular& sp, std::int64_t x, const FormFactors& ff,
                            const SpecularTransfer& transfer, RowScratch& scratch,
                            std::int64_t at) {
  auto& [link_of, pair_of, f_to, rows] = scratch;
  const std::int32_t i = sp.reflector[x];
  const std::int64_t first = sp.link_start[i], last = sp.link_start[i + 1];
  const std::int64_t pairs = sp.pair_start[x], pairs_end = sp.pair_start[x + 1];
  for (auto l = first; l < last; ++l) link_of[sp.links[l].to] = l;
  for (auto q = pairs; q < pairs_end; ++q)
    pair_of[sp.pair_source[q]] = static_cast<std::int32_t>(q - pairs);
  for (auto [k, f] : ff.f.row(i)) f_to[k] = f;
  rows.resize(static_cast<std::size_t>(last - first));
  std::vector<double> reflected(static_cast<std::size_t>(pairs_end - pairs), 0.0);
  for (auto e = transfer.start[i]; e < transfer.start[i + 1]; ++e) {
    const std::int64_t l = link_of[transfer.to[e]];
    const std::int32_t q = pair_of[transfer.from[e]];
    const double f_ik = f_to[transfer.to[e]];
    if (l < 0 || q < 0 || !(f_ik > 0.0) || !(transfer.fraction[e] > 0.0f)) continue;
    rows[l - first].emplace_back(q, transfer.fraction[e] / f_ik);
    if (!sp.links_only[l]) reflected[q] += transfer.fraction[e];
  }
  for (std::size_t q = 0; q < reflected.size(); ++q)
    sp.pair_reflected[pairs + q] = static_cast<float>(reflected[q]);
  const std::int64_t begin = at;
  for (auto l = first; l < last; ++l) {
    auto& row = rows[l - first];
    std::sort(row.begin(), row.end());
    const std::int64_t row_begin = at;
    for (std::size_t a = 0; a < row.size(); ++a) {
      if (a > 0 && row[a].first == row[a - 1].first) {
        sp.rows.value[at - 1] += static_cast<float>(row[a].second);
        continue;
      }
      sp.rows.column[at] = row[a].first;
      sp.rows.value[at++] = static_cast<float>(row[a].second);
    }
    sp.rows.start[l + 1] = at - row_begin;
    row.clear();
  }
  for (auto l = first; l < last; ++l) link_of[sp.links[l].to] = -1;
  for (auto q = pairs; q < pairs_end; ++q) pair_of[sp.pair_source[q]] = -1;
  for (auto [k, f] : ff.f.row(i)) f_to[k] = 0.0;
  return at - begin;
}

// Every reflector's rows, a reflector a task, each written from an offset of its transfer
// entries (its rows have no more entries than those), then joined by close_gaps: no second copy
// of the rows is held (the room's are 7 million entries).
void add_rows(RootSpecular& sp, const FormFactors& ff, const SpecularTransfer& transfer) {
  const auto reflectors = static_cast<std::int64_t>(sp.reflector.size());
  std::vector<std::int64_t> offset(reflectors + 1, 0), written(reflectors, 0);
  for (std::int64_t x = 0; x < reflectors; ++x) {
    const std::int32_t i = sp.reflector[x];
    offset[x + 1] = offset[x] + transfer.start[i + 1] - transfer.start[i];
  }
  Csr<float>& rows = sp.rows;
  rows.rows = sp.num_links();
  rows.cols = sp.max_pairs;
  if (reflectors == 0) return;
  rows.start.assign(static_cast<std::size_t>(rows.rows + 1), 0);
  resize_on_huge_pages(rows.column, static_cast<std::size_t>(offset[reflectors]));
  resize_on_huge_pages(rows.value, static_cast<std::size_t>(offset[reflectors]));
#pragma omp parallel
  {
    RowScratch scratch(sp.link_start.size() - 1);  // a slot per root
#pragma omp for schedule(dynamic, 1)
    for (std::int64_t x = 0; x < reflectors; ++x)
      written[x] = reflector_rows(sp, x, ff, transfer, scratch, offset[x]);
  }
  close_gaps(rows.column, offset, written);
  close_gaps(rows.value, offset, written);
  for (std::int64_t l = 0; l < rows.rows; ++l) rows.start[l + 1] += rows.start[l];
}

// Each link entry of a reflector's tree rows names its source's root: its pair.
void add_entry_pairs(RootSpecular& sp, const TreeRows& tree) {
  const auto reflectors = static_cast<std::int64_t>(sp.reflector.size());
  sp.entry_start.resize(reflectors);
  std::int64_t total = 0;
  for (std::int64_t x = 0; x < reflectors; ++x) {
    sp.entry_start[x] = total;
    total += tree.end_entry(sp.reflector[x]) - tree.first_entry(sp.reflector[x]);
  }
  sp.entry_pair.resize(static_cast<std::size_t>(total));
#pragma omp parallel for schedule(dynamic, 4)
  for (std::int64_t x = 0; x < reflectors; ++x) {
    const std::int32_t i = sp.reflector[x];
    std::int32_t* pair = sp.entry_pair.data() + sp.entry_start[x];
    for (auto e = tree.first_entry(i); e < tree.end_entry(i); ++e)
      *pair++ = find_pair(sp, x, tree.root_of(tree.column[e]));
  }
}

// The receivers, eq. H3 (a): every entry r <- s of the rows of a tree k with a diffuse part
// names the link S_{root(s)->k}, if any. Trees in the order their first link names them.
void add_receivers(RootSpecular& sp, const PatchSet& roots, const std::vector<Material>& materials,
                   const TreeRows& tree) {
  sp.receive_start.assign(roots.size(), -1);
  std::vector<std::int32_t> receivers;
  std::int64_t total = 0;
  for (std::size_t x = 0; x < sp.links.size(); ++x) {
    const PatchId k = sp.links[x].to;
    if (sp.links_only[x]) continue;  // its light is on the image links (eq. H4)
    if (sp.receive_start[k] >= 0 || !(materials[roots[k].material].diffuse.maxCoeff() > 0.0))
      continue;
    sp.receive_start[k] = total;
    total += tree.end_entry(k) - tree.first_entry(k);
    receivers.push_back(k);
  }
  sp.receive_entry.resize(static_cast<std::size_t>(total));
#pragma omp parallel for schedule(dynamic, 4)
  for (std::int64_t n = 0; n < static_cast<std::int64_t>(receivers.size()); ++n) {
    const std::int32_t k = receivers[n];
    std::int32_t* link = sp.receive_entry.data() + sp.receive_start[k];
    for (auto e = tree.first_entry(k); e < tree.end_entry(k); ++e) {
      const std::int64_t l = find_link(sp, tree.root_of(tree.column[e]), k);
      *link++ = static_cast<std::int32_t>(l >= 0 && sp.links_only[l] ? -1 : l);
    }
  }
}

}  // namespace

RootSpecular build_root_specular(const ElementHierarchy& h, const std::vector<Material>& materials,
                                 const FormFactors& ff, const SpecularTransfer& transfer) {
  const HierarchicalOperator& op = *h.op();
  const TreeRows tree{op.tree_start_, op.links_.start, op.links_.column};
  RootSpecular sp;
  add_links(sp, h.roots(), materials, ff, transfer);
  mark_links_only(sp, h.roots(), materials, h.mirrors());
  add_pairs(sp, ff);
  add_rows(sp, ff, transfer);
  add_entry_pairs(sp, tree);
  add_receivers(sp, h.roots(), materials, tree);
  // Eq. H4: what each image link's source sends toward the mirror root its path crosses.
  sp.image_link.resize(op.images_.column.size());
#pragma omp parallel for schedule(dynamic, 4096)
  for (std::int64_t e = 0; e < static_cast<std::int64_t>(sp.image_link.size()); ++e)
    sp.image_link[e] = static_cast<std::int32_t>(
        find_link(sp, tree.root_of(op.images_.column[e]), op.image_root_[e]));
  return sp;
}

}  // namespace polyrad
