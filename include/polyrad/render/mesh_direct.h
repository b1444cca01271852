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
// Cost: one application of T per emitting object; memory 12 bytes per B unknown and object.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "polyrad/geometry/mesher.h"
#include "polyrad/transport/transport.h"

namespace polyrad {

struct MeshDirect {
  int objects = 0;                          // emitting objects
  std::vector<std::int32_t> column;         // per object: the patch whose emission stands for it
  std::vector<std::array<float, 3>> value;  // (l, o) at l * objects + o, l over the B unknowns

  const std::array<float, 3>& at(std::int64_t l, int o) const {
    return value[static_cast<std::size_t>(l * objects + o)];
  }
  std::size_t bytes() const { return value.size() * sizeof(value[0]) + column.size() * 4; }
};

MeshDirect mesh_direct(const TransportOperator& t, const PatchSet& patches);

}  // namespace polyrad
