// The camera gather: each pixel as a fixed linear combination of the unknowns, image = G u.
//
// Per primary ray hitting patch i at x, seen from direction v (papers/glossy-radiosity.md,
// section 7):
//   diffuse part  B_i (flat) or B interpolated from the corners of i (smooth: each corner
//                 averages the patches of the same object and orientation that share it);
//   mirror part   s_i * L_{j->i}, j met by the reflected ray;
//   glossy part   s_i * mean over a fixed set of lobe samples of beta * L_{j->i}, combined by
//                 multiple importance with a fixed set of points on the lights (patches of
//                 objects with an "emission" key, drawn by area): the lobe samples alone
//                 rarely find a small lamp, so a rough surface under it comes out speckled;
// with L_{j->i} = B_j + S_{j->i}. Pixels average a fixed grid of sub-pixel rays. Nothing here
// depends on the values of u, so the view-mode precompute folds G into its operator.
//
//   Gather g = build_gather(*world, t.layout(), {});      // the scene's camera
//   Image img = apply_gather(g, solution.u);
//
// Cost: pixels x sub-pixel rays x (1 + lobe samples + light samples) rays to build; memory 16
// bytes per entry.
#pragma once

#include <array>

#include "polyrad/render/image.h"
#include "polyrad/scene/camera.h"
#include "polyrad/transport/transport.h"
#include "polyrad/util/enum_names.h"
#include "polyrad/util/sparse.h"
#include "polyrad/world/world.h"

namespace polyrad {

enum class DiffuseMode { kFlat, kSmooth };
template <>
struct EnumNames<DiffuseMode> {
  static constexpr const char* kind = "diffuse shading";
  static constexpr std::array<std::pair<DiffuseMode, const char*>, 2> table{
      {{DiffuseMode::kSmooth, "smooth"}, {DiffuseMode::kFlat, "flat"}}};
};

struct GatherOptions {
  DiffuseMode diffuse = DiffuseMode::kSmooth;
  int pixel_grid = 2;     // sub-pixel rays per side (2: four rays a pixel)
  int lobe_samples = 16;  // fixed lobe samples of a glossy hit
  int light_samples = 4;  // points on the lights per glossy hit (0: the lobe samples alone)
  std::uint64_t seed = 11;
};

using Rgbf = std::array<float, 3>;

struct Gather {
  int width = 0, height = 0;
  GatherOptions options;  // what built it
  Csr<Rgbf> g;            // row = pixel (row-major from the top-left), column = unknown
  long long rays = 0;
  double seconds = 0.0;
  std::size_t bytes() const { return g.bytes(); }
};

// The gather of the world's camera, or of another camera (a solution operator relit from
// elsewhere).
Gather build_gather(const World& world, const UnknownLayout& layout,
                    const GatherOptions& options = {});
Gather build_gather(const World& world, const Camera& camera, const UnknownLayout& layout,
                    const GatherOptions& options = {});

Image apply_gather(const Gather& gather, const Field& u);

}  // namespace polyrad
