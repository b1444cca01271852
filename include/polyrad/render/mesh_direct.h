// The direct light as the mesh holds it: for each B unknown l and each emitting object o,
//   D(l, o) = (T e_o)_l,   e_o = unit emission on every patch of o (zero elsewhere),
// the part of B_l that o's emission puts there in one bounce. B_l - E_l - sum_o D(l, o) e_o is
// then the light l reflects beyond the direct light: what the final gather reads from the mesh
// at its own hit with IndirectMode::kMesh (render/camera_gather.h), which computes the direct
// light at the pixel instead.
//
// Objects, not patches: an object's patches always share its emission (the scene gives one per
// object, relighting sets one per object), so a gather row may put sum_o D(l, o) on one patch of
// o, its first (`column`), and the image is the same. Per patch it would hold 22 times more on
// the room (135 lamp patches, 6 lamps).
//
//   MeshDirect d = mesh_direct(sys->transport, world->patches());
//   Gather g = build_gather(*world, t.layout(), options, &d);
//
// With the scene's materials it also holds, for each link unknown S_{j->i} sent by a planar
// mirror j (a delta lobe, is_planar_mirror), the same for that link: (T e_o)_{j->i} = s_j sum_{k in
// o} R_kji, the part of S_{j->i} that is o's light reflected once by j. The final gather's mirror
// images (render/ camera_gather.h) take that part at the pixel itself, so its reads of those links
// leave it out. With `mirrored` as well, per B unknown l and object o, what those links bring l in
// the bounce after, (T M T e_o)_l with M keeping only the mirrors' links: the part of B_l that a
// final gather reading the indirect light from the mesh leaves out where it draws the images.
//
// Cost: one application of T per emitting object; memory 12 bytes per B unknown and object, and
// per mirror link and object.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "polyrad/geometry/mesher.h"
#include "polyrad/scene/brdf.h"
#include "polyrad/transport/mirror_planes.h"
#include "polyrad/transport/transport.h"

namespace polyrad {

struct MeshDirect {
  int objects = 0;                          // emitting objects
  std::vector<std::int32_t> column;         // per object: the patch whose emission stands for it
  std::vector<std::array<float, 3>> value;  // (l, o) at l * objects + o, l over the B unknowns
  // The mirrors' links (empty unless made with materials): per link unknown (its index less the
  // B unknowns) its row of link_value, -1 for a link not sent by a mirror.
  std::vector<std::int32_t> link_row;
  std::vector<std::array<float, 3>> link_value;  // (row, o) at row * objects + o
  // (l, o) at l * objects + o over the B unknowns: o's light reflected by a mirror to l (empty
  // unless asked for).
  std::vector<std::array<float, 3>> mirrored;

  const std::array<float, 3>& at(std::int64_t l, int o) const {
    return value[static_cast<std::size_t>(l * objects + o)];
  }
  bool has_links() const { return !link_row.empty(); }
  // The row of link unknown `unknown` (an index into the whole layout), or -1.
  std::int32_t link_row_of(std::int64_t unknown, std::int64_t b_unknowns) const {
    return link_row[static_cast<std::size_t>(unknown - b_unknowns)];
  }
  const std::array<float, 3>& link_at(std::int32_t row, int o) const {
    return link_value[static_cast<std::size_t>(row) * objects + o];
  }
  const std::array<float, 3>& mirrored_at(std::int64_t l, int o) const {
    return mirrored[static_cast<std::size_t>(l * objects + o)];
  }
  std::size_t bytes() const {
    return (value.size() + link_value.size() + mirrored.size()) * sizeof(value[0]) +
           (column.size() + link_row.size()) * 4;
  }
};

// With materials, the planar mirrors' links too, and with mirrored their bounce after (above).
// One application of T per emitting object, two with mirrored.
MeshDirect mesh_direct(const TransportOperator& t, const PatchSet& patches,
                       const std::vector<Material>* materials = nullptr, bool mirrored = false);

}  // namespace polyrad
