// The specular part of the hierarchical mesh (hierarchy.h, RootSpecular; eq. H3 and section 12.6
// of papers/glossy-radiosity.md): root form factors from the links, the root links and their
// rows, and the two couplings with the leaves.
#include <algorithm>
#include <tuple>

#include "polyrad/transport/hierarchy.h"

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

}  // namespace

RootSpecular build_root_specular(const ElementHierarchy& h, const std::vector<Material>& materials,
                                 const FormFactors& ff, const SpecularTransfer& transfer) {
  const PatchSet& roots = h.roots();
  const auto count = static_cast<std::int32_t>(h.num_roots());
  const HierarchicalOperator& op = *h.op();
  // The root (tree) of an operator node: trees are consecutive runs of nodes.
  auto root_of = [&](std::int32_t node) {
    return static_cast<std::int32_t>(
        std::upper_bound(op.tree_start_.begin(), op.tree_start_.end(), node) -
        op.tree_start_.begin() - 1);
  };
  RootSpecular sp;
  // The links (section 3's fixed point on the roots) and their flux weights tau_ik.
  sp.links = active_specular_links(roots, materials, ff, transfer);
  sp.link_start.assign(count + 1, 0);
  for (const Link& l : sp.links) ++sp.link_start[l.from + 1];
  for (std::int32_t r = 0; r < count; ++r) sp.link_start[r + 1] += sp.link_start[r];
  for (const Link& l : sp.links) {
    sp.flux_weight.push_back(kPi * ff.area[l.from] * ff.at(l.from, l.to));
    sp.colour.push_back(materials[roots[l.from].material].specular.cast<float>());
  }
  // The reflectors with links and their pairs (row i of the root form factors).
  for (std::int32_t i = 0; i < count; ++i)
    if (sp.link_start[i + 1] > sp.link_start[i]) sp.reflector.push_back(i);
  const auto reflectors = static_cast<std::int64_t>(sp.reflector.size());
  sp.pair_start.push_back(0);
  for (std::int64_t x = 0; x < reflectors; ++x) {
    const std::int32_t i = sp.reflector[x];
    for (auto [j, f] : ff.f.row(i)) {
      sp.pair_source.push_back(j);
      sp.pair_f.push_back(f);
      sp.pair_link.push_back(find_link(sp, j, i));
      sp.pair_reflected.push_back(0.0f);
    }
    sp.pair_start.push_back(static_cast<std::int64_t>(sp.pair_source.size()));
    sp.max_pairs = std::max(sp.max_pairs, sp.pair_start[x + 1] - sp.pair_start[x]);
  }
  // The rows, eq. H3 (b): S_{i->k} reads pair (i, j) with weight R_jik / F_ik. One reflector at
  // a time, in link order, with its links, pairs and form factors in slots indexed by root (no
  // search per transfer entry: the room has 7 million, the rows took 1.2 s with searches).
  std::vector<std::int64_t> link_of(count, -1);
  std::vector<std::int32_t> pair_of(count, -1);
  std::vector<double> f_to(count, 0.0);
  std::vector<std::vector<std::pair<std::int32_t, double>>> rows;
  std::vector<double> reflected;
  sp.rows.cols = static_cast<std::int64_t>(sp.max_pairs);
  for (std::int64_t x = 0; x < reflectors; ++x) {
    const std::int32_t i = sp.reflector[x];
    const std::int64_t first = sp.link_start[i], last = sp.link_start[i + 1];
    const std::int64_t pairs = sp.pair_start[x], pairs_end = sp.pair_start[x + 1];
    for (auto l = first; l < last; ++l) link_of[sp.links[l].to] = l;
    for (auto q = pairs; q < pairs_end; ++q)
      pair_of[sp.pair_source[q]] = static_cast<std::int32_t>(q - pairs);
    for (auto [k, f] : ff.f.row(i)) f_to[k] = f;
    rows.resize(static_cast<std::size_t>(last - first));
    reflected.assign(static_cast<std::size_t>(pairs_end - pairs), 0.0);
    for (auto e = transfer.start[i]; e < transfer.start[i + 1]; ++e) {
      const std::int64_t l = link_of[transfer.to[e]];
      const std::int32_t q = pair_of[transfer.from[e]];
      const double f_ik = f_to[transfer.to[e]];
      if (l < 0 || q < 0 || !(f_ik > 0.0) || !(transfer.fraction[e] > 0.0f)) continue;
      rows[l - first].emplace_back(q, transfer.fraction[e] / f_ik);
      reflected[q] += transfer.fraction[e];
    }
    for (std::size_t q = 0; q < reflected.size(); ++q)
      sp.pair_reflected[pairs + q] = static_cast<float>(reflected[q]);
    for (auto& row : rows) {
      std::sort(row.begin(), row.end());
      for (std::size_t a = 0; a < row.size(); ++a) {
        if (a > 0 && row[a].first == row[a - 1].first) {
          sp.rows.value.back() += static_cast<float>(row[a].second);
          continue;
        }
        sp.rows.column.push_back(row[a].first);
        sp.rows.value.push_back(static_cast<float>(row[a].second));
      }
      sp.rows.push_row();
      row.clear();
    }
    for (auto l = first; l < last; ++l) link_of[sp.links[l].to] = -1;
    for (auto q = pairs; q < pairs_end; ++q) pair_of[sp.pair_source[q]] = -1;
    for (auto [k, f] : ff.f.row(i)) f_to[k] = 0.0;
  }
  // Each link entry of a reflector's tree rows names its source's root: its pair.
  for (std::int64_t x = 0; x < reflectors; ++x) {
    const std::int32_t i = sp.reflector[x];
    const std::int32_t first = op.tree_start_[i], last = op.tree_start_[i + 1];
    sp.entry_start.push_back(static_cast<std::int64_t>(sp.entry_pair.size()));
    for (auto e = op.links_.start[first]; e < op.links_.start[last]; ++e)
      sp.entry_pair.push_back(find_pair(sp, x, root_of(op.links_.column[e])));
  }
  // The receivers, eq. H3 (a): every entry r <- s of the rows of a tree k with a diffuse part
  // names the link S_{root(s)->k}, if any.
  sp.receive_start.assign(count, -1);
  for (const Link& l : sp.links) {
    const PatchId k = l.to;
    if (sp.receive_start[k] >= 0 || !(materials[roots[k].material].diffuse.maxCoeff() > 0.0))
      continue;
    sp.receive_start[k] = static_cast<std::int64_t>(sp.receive_entry.size());
    const std::int32_t first = op.tree_start_[k], last = op.tree_start_[k + 1];
    for (auto e = op.links_.start[first]; e < op.links_.start[last]; ++e)
      sp.receive_entry.push_back(
          static_cast<std::int32_t>(find_link(sp, root_of(op.links_.column[e]), k)));
  }
  return sp;
}

}  // namespace polyrad
