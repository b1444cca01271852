// polyrad's shared vocabulary: vectors, colours, indices, and the conventions every module uses.
//
// Conventions, stated once:
// - Units are the scene file's own (the Cornell scenes use millimetres). Radiance and emission
//   are in arbitrary but consistent radiance units; flux is radiance * area * solid angle.
// - Right-handed world. A polygon's front side is the one from which its vertices run
//   counter-clockwise; its unit normal points out of the front side. Patches are one-sided:
//   they emit and reflect from the front only, and block light from both sides.
// - Index names of the link transport (papers/glossy-radiosity.md, eq. 7):
//     j  the patch light comes from,  i  the patch that reflects it,  k  the patch it goes to.
//   rho_jik, R_jik, W_jik follow that order. A link i->k is the ordered patch pair along which
//   radiance L_{i->k} leaves i toward k.
// - Colours are linear RGB, one value per channel; every equation holds per channel.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>  // cross products
#include <cstdint>
#include <numbers>

namespace polyrad {

using Vec3 = Eigen::Vector3d;
using Vec2 = Eigen::Vector2d;
using Rgb = Eigen::Array3d;

using PatchId = std::int32_t;  // index into PatchSet::patches
using LinkId = std::int32_t;   // index into TransportOperator::links
using ObjectId = std::int32_t;
using MaterialId = std::int32_t;

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kInvPi = 1.0 / std::numbers::pi;

// Luminance of linear sRGB, used where a colour has to be summarised by one number.
inline double luminance(const Rgb& c) { return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]; }

}  // namespace polyrad
