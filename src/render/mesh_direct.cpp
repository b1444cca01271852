// The direct light as the mesh holds it (render/mesh_direct.h).
#include "polyrad/render/mesh_direct.h"

#include <map>

#include "polyrad/transport/hierarchy.h"

namespace polyrad {

namespace {
std::array<float, 3> row_of(const Field& f, Eigen::Index r) {
  return {static_cast<float>(f(r, 0)), static_cast<float>(f(r, 1)), static_cast<float>(f(r, 2))};
}
}  // namespace

MeshDirect mesh_direct(const TransportOperator& t, const PatchSet& patches,
                       const std::vector<Material>* materials, bool mirrored) {
  MeshDirect d;
  std::map<ObjectId, int> index;  // emitting object -> its place, in order of first patch
  for (std::size_t p = 0; p < patches.size(); ++p)
    if (patches[p].emitter && index.emplace(patches[p].object, d.objects).second) {
      d.column.push_back(static_cast<std::int32_t>(p));
      ++d.objects;
    }
  const std::int64_t b = t.num_patches();
  d.value.assign(static_cast<std::size_t>(b * d.objects), {0.0f, 0.0f, 0.0f});
  // The world patch of each B unknown: itself, or the root its leaf lies under.
  const ElementHierarchy* h = t.layout().hierarchy.get();
  std::vector<ObjectId> object_of(static_cast<std::size_t>(b));
  for (std::int64_t l = 0; l < b; ++l) {
    const auto i = static_cast<int>(l);
    object_of[l] = patches[h ? h->elements()[h->element_of_leaf(i)].root : i].object;
  }
  // The links sent by a planar mirror, each given a row.
  const std::vector<Link>& links = t.layout().links;
  if (materials && !links.empty()) {
    d.link_row.assign(links.size(), -1);
    std::int32_t rows = 0;
    for (std::size_t l = 0; l < links.size(); ++l) {
      const Patch& from = patches[links[l].from];
      if (is_planar_mirror(from, (*materials)[from.material], patches.scene_diameter))
        d.link_row[l] = rows++;
    }
    d.link_value.assign(static_cast<std::size_t>(rows) * d.objects, {0.0f, 0.0f, 0.0f});
    if (mirrored) d.mirrored.assign(d.value.size(), {0.0f, 0.0f, 0.0f});
  }
  // A hierarchy's image links (eq. H4) bring a lamp's light through the mirrors in the same
  // bounce: that part is the mirrors', not the direct light.
  const bool images = h && !h->mirrors().empty();
  Field out, links_only, again, imaged;
  for (const auto& [object, o] : index) {
    std::vector<Rgb> unit(static_cast<std::size_t>(b), Rgb::Zero());
    for (std::int64_t l = 0; l < b; ++l)
      if (object_of[l] == object) unit[l] = Rgb::Ones();
    const Field e = t.emission(unit);
    t.apply(e, out);
    if (images) {
      imaged = Field::Zero(b, 3);
      h->op()->apply_images(e.data(), imaged.data(), 3);
      out.topRows(b) -= imaged;
    }
    for (std::int64_t l = 0; l < b; ++l)
      d.value[static_cast<std::size_t>(l * d.objects + o)] = row_of(out, l);
    // The mirrors' links, and for the bounce after T applied to them alone.
    if (!d.mirrored.empty()) links_only = Field::Zero(out.rows(), 3);
    for (std::size_t l = 0; l < d.link_row.size(); ++l) {
      if (d.link_row[l] < 0) continue;
      const auto u = static_cast<Eigen::Index>(b + static_cast<std::int64_t>(l));
      d.link_value[static_cast<std::size_t>(d.link_row[l]) * d.objects + o] = row_of(out, u);
      if (!d.mirrored.empty()) links_only.row(u) = out.row(u);
    }
    if (d.mirrored.empty()) continue;
    t.apply(links_only, again);
    if (images) {
      // The bounce after the mirrors' links, less what their image links carry on (light that
      // met two mirrors, which the images at the pixel do not draw), plus the lamp's light the
      // image links bring in one bounce.
      Field beyond = Field::Zero(b, 3);
      h->op()->apply_images(links_only.data(), beyond.data(), 3);
      again.topRows(b) += imaged - beyond;
    }
    for (std::int64_t l = 0; l < b; ++l)
      d.mirrored[static_cast<std::size_t>(l * d.objects + o)] = row_of(again, l);
  }
  return d;
}

}  // namespace polyrad
