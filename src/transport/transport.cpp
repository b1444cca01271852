// The transport operator (transport.h); equations from papers/glossy-radiosity.md.
#include "polyrad/transport/transport.h"

#include <algorithm>

#include "polyrad/transport/hierarchy.h"
#include "polyrad/transport/specular_transfer.h"
#include "polyrad/util/error.h"

namespace polyrad {

namespace {

struct Entry {
  std::int32_t column;
  double weight;
};

// Sorts a row's entries by column and sums duplicates.
void compact(std::vector<Entry>& row) {
  std::sort(row.begin(), row.end(),
            [](const Entry& a, const Entry& b) { return a.column < b.column; });
  size_t w = 0;
  for (size_t r = 0; r < row.size(); ++r) {
    if (w > 0 && row[w - 1].column == row[r].column)
      row[w - 1].weight += row[r].weight;
    else
      row[w++] = row[r];
  }
  row.resize(w);
}

// Reflector i's form factors F_ij by j and its links' unknowns by k (-1: no link i -> k), laid
// out densely while i's transfer entries are read, so that an entry searches only for the link
// j -> i that feeds it (the room's 7.4 million entries spent about a second in the two form
// factors' and the link i -> k's searches). One per thread, a float and an index per patch;
// filled for one reflector at a time and cleared after it.
class ReflectorLookup {
 public:
  explicit ReflectorLookup(PatchId n) : f_(n, 0.0f), link_(n, -1) {}
  void fill(const UnknownLayout& layout, const FormFactors& ff, PatchId i) {
    mark(layout, ff, i, true);
  }
  void clear(const UnknownLayout& layout, const FormFactors& ff, PatchId i) {
    mark(layout, ff, i, false);
  }
  double f(PatchId j) const { return f_[j]; }              // ff.at(i, j)
  Eigen::Index link(PatchId k) const { return link_[k]; }  // layout.link_unknown(i, k)

 private:
  // i's entries set to their values, or back to none.
  void mark(const UnknownLayout& layout, const FormFactors& ff, PatchId i, bool set) {
    for (auto [j, f_ij] : ff.f.row(i)) f_[j] = set ? f_ij : 0.0f;
    for (auto l = layout.link_start[i]; l < layout.link_start[i + 1]; ++l)
      link_[layout.links[l].to] = set ? layout.num_patches + l : -1;
  }
  std::vector<float> f_;
  std::vector<Eigen::Index> link_;
};

// Rows of the links of reflector i, eq. 7: S_{i->k} = s_i sum_j W_jik (B_j + S_{j->i}) with
// W_jik = R_jik F_ij / F_ik, from i's transfer entries. rows[l - link_start[i]] is link l's row.
void reflector_rows(const UnknownLayout& layout, const FormFactors& ff, PatchId i,
                    const TransferEntry* entries, std::size_t count,
                    std::vector<std::vector<Entry>>& rows, ReflectorLookup& lookup) {
  const auto first = layout.link_start[i], last = layout.link_start[i + 1];
  rows.resize(last - first);
  for (auto& r : rows) r.clear();
  lookup.fill(layout, ff, i);
  for (std::size_t e = 0; e < count; ++e) {
    PatchId j = entries[e].from, k = entries[e].to;
    Eigen::Index row = lookup.link(k);
    if (row < 0) continue;
    double w = entries[e].fraction * lookup.f(j) / lookup.f(k);
    auto& r = rows[row - layout.num_patches - first];
    r.push_back({j, w});
    Eigen::Index source = layout.link_unknown(j, i);
    if (source >= 0) r.push_back({static_cast<std::int32_t>(source), w});
  }
  lookup.clear(layout, ff, i);
  for (auto& r : rows) {
    compact(r);
    for (auto& e : r) e.weight = static_cast<float>(e.weight);  // as the stored operator keeps it
  }
}

// The candidate links of the fixed point below: every (i, k) that a transfer entry with a
// positive fraction names and with F_ik > 0, kept per reflector i sorted by k, so a lookup is a
// binary search in one short row (a std::map of the room's half million links cost 1.8 s a
// call). Each reflector's row is sorted and made distinct in place, within the span of its
// transfer entries, a reflector a task; close_gaps joins them.
struct CandidateLinks {
  std::vector<std::int64_t> row_start;
  std::vector<PatchId> to;

  CandidateLinks(const FormFactors& ff, const SpecularTransfer& st) {
    const auto n = static_cast<PatchId>(st.start.empty() ? 0 : st.start.size() - 1);
    const std::vector<std::int64_t> offset(st.start.begin(), st.start.begin() + n);
    std::vector<std::int64_t> written(n, 0);
    to.resize(n > 0 ? st.start[n] : 0);
#pragma omp parallel for schedule(dynamic, 16)
    for (PatchId i = 0; i < n; ++i) {
      const auto first = to.begin() + st.start[i];
      auto last = first;
      for (auto e = st.start[i]; e < st.start[i + 1]; ++e)
        if (!(st.fraction[e] <= 0.0f)) *last++ = st.to[e];
      std::sort(first, last);
      last = std::unique(first, last);
      last = std::remove_if(first, last, [&](PatchId k) { return ff.at(i, k) <= 0.0; });
      written[i] = last - first;
    }
    close_gaps(to, offset, written);
    row_start.assign(n + 1, 0);
    for (PatchId i = 0; i < n; ++i) row_start[i + 1] = row_start[i] + written[i];
  }
  PatchId reflectors() const { return static_cast<PatchId>(row_start.size()) - 1; }
  std::int64_t size() const { return static_cast<std::int64_t>(to.size()); }
  // The index of candidate (i, k), or -1.
  std::int64_t index_of(PatchId i, PatchId k) const {
    if (i < 0 || i >= reflectors()) return -1;
    const auto first = to.begin() + row_start[i], last = to.begin() + row_start[i + 1];
    const auto it = std::lower_bound(first, last, k);
    return it != last && *it == k ? it - to.begin() : -1;
  }
};

}  // namespace

// The fixed point of transport.h over the candidate links. Sources that can shine light their
// links at once; the others (pure reflectors) wait on the link that feeds them, and those
// entries are swept until nothing changes (at most as many rounds as the longest chain of
// reflectors, plus one). A reflector's entries mark only its own candidates: a reflector a task.
std::vector<Link> active_specular_links(const PatchSet& patches,
                                        const std::vector<Material>& materials,
                                        const FormFactors& ff, const SpecularTransfer& st) {
  auto b_can_shine = [&](PatchId j) {
    // An emitter counts even when dark: relighting may switch it on.
    const Patch& p = patches[j];
    return p.emitter || materials[p.material].diffuse.maxCoeff() > 0.0;
  };
  const CandidateLinks candidates(ff, st);
  const PatchId n = candidates.reflectors();
  std::vector<char> active(candidates.size(), 0);
  using Wait = std::pair<std::int64_t, std::int64_t>;  // (link, the link it waits on)
  std::vector<std::vector<Wait>> waits(n);
#pragma omp parallel for schedule(dynamic, 16)
  for (PatchId i = 0; i < n; ++i)
    for (auto e = st.start[i]; e < st.start[i + 1]; ++e) {
      if (st.fraction[e] <= 0.0f) continue;
      const std::int64_t c = candidates.index_of(i, st.to[e]);
      if (c < 0) continue;  // no form factor F_ik
      const PatchId j = st.from[e];
      if (b_can_shine(j)) {
        active[c] = 1;
      } else if (const std::int64_t source = candidates.index_of(j, i); source >= 0) {
        waits[i].emplace_back(c, source);
      }
    }
  for (bool changed = true; changed;) {
    changed = false;
    for (const auto& row : waits)
      for (const auto& [c, source] : row)
        if (!active[c] && active[source]) {
          active[c] = 1;
          changed = true;
        }
  }
  std::vector<Link> links;
  for (PatchId i = 0; i < n; ++i)
    for (auto c = candidates.row_start[i]; c < candidates.row_start[i + 1]; ++c)
      if (active[c]) links.push_back(Link{i, candidates.to[c]});
  return links;
}

Eigen::Index UnknownLayout::link_unknown(PatchId i, PatchId k) const {
  auto first = links.begin() + link_start[i];
  auto last = links.begin() + link_start[i + 1];
  auto it = std::lower_bound(first, last, k, [](const Link& l, PatchId key) { return l.to < key; });
  if (it == last || it->to != k) return -1;
  return num_patches + (it - links.begin());
}

TransportOperator build_transport(const PatchSet& patches, const std::vector<Material>& materials,
                                  const FormFactors& ff, const SpecularTransfer* specular,
                                  const OnTheFlySpecular* on_the_fly) {
  TransportOperator t;
  if (on_the_fly) t.on_the_fly_ = std::make_shared<OnTheFlySpecular>(*on_the_fly);
  const auto n = static_cast<PatchId>(patches.size());
  t.layout_.num_patches = n;
  for (const auto& p : patches.patches) t.patch_emission_.push_back(p.emission);
  if (const Material* m = brightest_material(materials)) {  // a_max
    t.max_albedo_ = m->albedo_bound().maxCoeff();
    t.brightest_material_ = m->name;
  }

  auto& links = t.layout_.links;
  auto& link_start = t.layout_.link_start;
  if (specular) links = active_specular_links(patches, materials, ff, *specular);
  link_start.assign(n + 1, 0);
  for (const auto& l : links) ++link_start[l.from + 1];
  for (PatchId i = 0; i < n; ++i) link_start[i + 1] += link_start[i];

  // Links into each patch, for the diffuse rows: (link, F_ij) of every active j -> i.
  std::vector<std::vector<Entry>> incoming(n);
  for (LinkId l = 0; l < t.num_links(); ++l) {
    const Link& link = links[l];
    incoming[link.to].push_back({n + l, ff.at(link.to, link.from)});
  }

  t.weights_.cols = t.size();
  std::vector<Entry> row;
  // Diffuse rows, eq. 6: B_i = E_i + d_i sum_j F_ij (B_j + S_{j->i}).
  for (PatchId i = 0; i < n; ++i) {
    const Material& m = materials[patches[i].material];
    row.clear();
    if (m.diffuse.maxCoeff() > 0.0) {  // a pure mirror needs no diffuse row
      for (auto [j, f_ij] : ff.f.row(i)) row.push_back({j, f_ij});
      row.insert(row.end(), incoming[i].begin(), incoming[i].end());
      compact(row);
    }
    for (const auto& e : row) {
      t.weights_.column.push_back(e.column);
      t.weights_.value.push_back(static_cast<float>(e.weight));
    }
    t.weights_.push_row();
    t.row_colour_.push_back(m.diffuse.cast<float>());
    t.layout_.flux_weight.push_back(kPi * ff.area[i]);
  }
  t.nnz_diffuse_ = t.weights_.nnz();

  // Specular rows, eq. 7 (reflector_rows), stored unless they are recomputed on the fly. Each
  // reflector's rows are its own (a reflector a task); they are laid out in order below.
  std::vector<std::vector<Entry>> link_rows(links.size());
  if (specular && !on_the_fly) {
#pragma omp parallel
    {
      std::vector<TransferEntry> entries;
      std::vector<std::vector<Entry>> rows;
      ReflectorLookup lookup(n);
#pragma omp for schedule(dynamic, 16)
      for (PatchId i = 0; i < n; ++i) {
        if (t.layout_.link_start[i + 1] == t.layout_.link_start[i]) continue;
        entries.clear();
        for (auto e = specular->start[i]; e < specular->start[i + 1]; ++e)
          entries.push_back({specular->from[e], specular->to[e], specular->fraction[e]});
        reflector_rows(t.layout_, ff, i, entries.data(), entries.size(), rows, lookup);
        for (size_t r = 0; r < rows.size(); ++r)
          link_rows[t.layout_.link_start[i] + r] = std::move(rows[r]);
      }
    }
  }
  std::size_t nnz = t.weights_.column.size();
  for (const auto& r : link_rows) nnz += r.size();
  t.weights_.column.reserve(nnz);
  t.weights_.value.reserve(nnz);
  t.weights_.start.reserve(t.weights_.start.size() + links.size());
  t.row_colour_.reserve(t.row_colour_.size() + links.size());
  t.layout_.flux_weight.reserve(t.layout_.flux_weight.size() + links.size());
  for (LinkId l = 0; l < t.num_links(); ++l) {
    for (const auto& e : link_rows[l]) {
      t.weights_.column.push_back(e.column);
      t.weights_.value.push_back(static_cast<float>(e.weight));
    }
    std::vector<Entry>().swap(link_rows[l]);  // copied: not held twice
    t.weights_.push_row();
    const Link& link = links[l];
    t.row_colour_.push_back(materials[patches[link.from].material].specular.cast<float>());
    t.layout_.flux_weight.push_back(kPi * ff.area[link.from] * ff.at(link.from, link.to));
  }
  return t;
}

std::string TransportOperator::divergence_hint() const {
  if (max_albedo_ <= 1.0) return {};
  return "material '" + brightest_material_ +
         "' has diffuse + specular = " + std::to_string(max_albedo_) +
         " > 1: it reflects more light than it receives";
}

Field TransportOperator::emission() const { return emission(patch_emission_); }

const Field* TransportOperator::solution_guess() const {
  const ElementHierarchy* h = layout_.hierarchy.get();
  return h && h->solution_guess().rows() == size() ? &h->solution_guess() : nullptr;
}

Field TransportOperator::emission(const std::vector<Rgb>& patch_emission) const {
  Field e = Field::Zero(size(), 3);
  for (int i = 0; i < layout_.num_patches; ++i) e.row(i) = patch_emission[i].matrix().transpose();
  return e;
}

void TransportOperator::recompute_link_rows(const double* in, double* out, Eigen::Index width,
                                            bool in_place, const Field* e) const {
  const OnTheFlySpecular& src = *on_the_fly_;
  const auto n = static_cast<PatchId>(layout_.num_patches);
  auto one = [&](PatchId i, std::vector<TransferEntry>& entries,
                 std::vector<std::vector<Entry>>& rows, ReflectorLookup& lookup,
                 std::vector<double>& acc) {
    if (layout_.link_start[i + 1] == layout_.link_start[i]) return;
    entries.clear();
    specular_entries_of(*src.patches, (*src.materials)[(*src.patches)[i].material], *src.ff,
                        *src.caster, src.options, i, entries);
    reflector_rows(layout_, *src.ff, i, entries.data(), entries.size(), rows, lookup);
    for (size_t r = 0; r < rows.size(); ++r) {
      const Eigen::Index row = n + layout_.link_start[i] + static_cast<Eigen::Index>(r);
      std::fill(acc.begin(), acc.end(), 0.0);
      const double* x_base = in_place ? out : in;
      for (const auto& entry : rows[r]) {
        const double* x = x_base + width * entry.column;
        for (Eigen::Index c = 0; c < width; ++c) acc[c] += entry.weight * x[c];
      }
      const auto& colour = row_colour_[row];
      double* y = out + width * row;
      for (Eigen::Index c = 0; c < width; ++c)
        y[c] = (e ? (*e)(row, c) : 0.0) + colour[c % 3] * acc[c];
    }
  };
  if (in_place) {  // Gauss-Seidel: reflectors in order, as the stored rows are
    std::vector<TransferEntry> entries;
    std::vector<std::vector<Entry>> rows;
    ReflectorLookup lookup(n);
    std::vector<double> acc(width);
    for (PatchId i = 0; i < n; ++i) one(i, entries, rows, lookup, acc);
    return;
  }
#pragma omp parallel
  {
    std::vector<TransferEntry> entries;
    std::vector<std::vector<Entry>> rows;
    ReflectorLookup lookup(n);
    std::vector<double> acc(width);
#pragma omp for schedule(dynamic, 1)
    for (PatchId i = 0; i < n; ++i) one(i, entries, rows, lookup, acc);
  }
}

void TransportOperator::apply(const Field& in, Field& out) const {
  const Eigen::Index rows = size();
  out.resize(rows, 3);
  if (hierarchy_) return hierarchy_->apply(in.data(), out.data(), 3);
#pragma omp parallel for schedule(dynamic, 256)
  for (Eigen::Index r = 0; r < rows; ++r) {
    double a[3] = {0.0, 0.0, 0.0};
    weights_.accumulate_row(r, in.data(), 3, a);
    const auto& c = row_colour_[r];
    for (int ch = 0; ch < 3; ++ch) out(r, ch) = c[ch] * a[ch];
  }
  if (on_the_fly_) recompute_link_rows(in.data(), out.data(), 3, false, nullptr);
}

void apply_weighted_rows(const Csr<float>& weights, const std::vector<Eigen::Array3f>& row_colour,
                         const FieldBlock& in, FieldBlock& out) {
  const auto rows = static_cast<Eigen::Index>(weights.rows);
  const Eigen::Index width = in.cols();
  out.resize(rows, width);
#pragma omp parallel
  {
    std::vector<double> acc(width);
#pragma omp for schedule(dynamic, 64)
    for (Eigen::Index r = 0; r < rows; ++r) {
      std::fill(acc.begin(), acc.end(), 0.0);
      weights.accumulate_row(r, in.data(), width, acc.data());
      const auto& colour = row_colour[r];
      double* y = out.data() + width * r;
      for (Eigen::Index c = 0; c < width; ++c) y[c] = colour[c % 3] * acc[c];
    }
  }
}

void TransportOperator::apply(const FieldBlock& in, FieldBlock& out) const {
  if (hierarchy_) {
    out.resize(in.rows(), in.cols());
    return hierarchy_->apply(in.data(), out.data(), in.cols());
  }
  apply_weighted_rows(weights_, row_colour_, in, out);
  if (on_the_fly_) recompute_link_rows(in.data(), out.data(), in.cols(), false, nullptr);
}

void TransportOperator::apply_channel(const double* in, double* out, int channel) const {
  if (hierarchy_) return hierarchy_->apply(in, out, 1, channel);
  if (on_the_fly_) {  // the recomputed rows work on whole fields
    Field a = Field::Zero(size(), 3), b;
    for (Eigen::Index r = 0; r < size(); ++r) a(r, channel) = in[r];
    apply(a, b);
    for (Eigen::Index r = 0; r < size(); ++r) out[r] = b(r, channel);
    return;
  }
  const Eigen::Index rows = size();
#pragma omp parallel for schedule(dynamic, 256)
  for (Eigen::Index r = 0; r < rows; ++r) {
    double a = 0.0;
    weights_.accumulate_row(r, in, 1, &a);
    out[r] = row_colour_[r][channel] * a;
  }
}

void TransportOperator::gauss_seidel_sweep(const Field& e, Field& u) const {
  if (hierarchy_) return hierarchy_->gauss_seidel_sweep(e, u);
  // Stored rows (all of them, or only the diffuse ones when the link rows are recomputed).
  const Eigen::Index rows = on_the_fly_ ? layout_.num_patches : size();
  for (Eigen::Index r = 0; r < rows; ++r) {
    double a[3] = {0.0, 0.0, 0.0};
    weights_.accumulate_row(r, u.data(), 3, a);
    const auto& c = row_colour_[r];
    for (int ch = 0; ch < 3; ++ch) u(r, ch) = e(r, ch) + c[ch] * a[ch];
  }
  if (on_the_fly_) recompute_link_rows(nullptr, u.data(), 3, true, &e);
}

Eigen::Array3d TransportOperator::flux_norm_channels(const Field& f) const {
  Eigen::Array3d n = Eigen::Array3d::Zero();
  for (Eigen::Index r = 0; r < f.rows(); ++r)
    n += layout_.flux_weight[r] * f.row(r).array().abs().transpose();
  return n;
}

std::size_t TransportOperator::bytes() const {
  return weights_.bytes() + row_colour_.size() * sizeof(Eigen::Array3f) +
         layout_.links.size() * sizeof(Link) + layout_.link_start.size() * sizeof(std::int64_t) +
         (hierarchy_ ? hierarchy_->bytes() : 0);
}

}  // namespace polyrad
