// The final gather (camera_gather.h, GatherKind::kFinal) against exact answers: a penumbra by
// quadrature of the visible light, furnaces at E / (1 - a), and the folded operator.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

#include "polyrad/io/prt_file.h"
#include "polyrad/render/camera_gather.h"
#include "polyrad/render/image_compare.h"
#include "polyrad/render/path_tracer.h"
#include "polyrad/solve/series_precompute.h"
#include "polyrad/solve/solver.h"
#include "polyrad/transport/system.h"
#include "polyrad/util/hash.h"
#include "test_support.h"

namespace polyrad {
namespace {

// The final gather with the command line's defaults, or other counts.
GatherOptions final_options(int gather_samples = -1, int light_samples = -1) {
  GatherOptions o = GatherOptions::final_gather();
  if (gather_samples > 0) o.gather_samples = gather_samples;
  if (light_samples >= 0) o.light_samples = light_samples;
  return o;
}

SolveResult converged(const RadiositySystem& sys) {
  SolveOptions o;
  o.tolerance = 1e-10;
  SolveResult r = solve(sys.transport, sys.transport.emission(), o);
  EXPECT_TRUE(r.ok()) << r.message;
  return r;
}

// The image of solution u through a gather with options o; rays, if given, the rays it cast.
Image gather_image(const RadiositySystem& sys, const Field& u, const GatherOptions& o,
                   long long* rays = nullptr) {
  const auto direct = mesh_direct_for(o, sys.transport, *sys.world);
  Gather g = build_gather(*sys.world, sys.transport.layout(), o, direct.get());
  if (rays) *rays = g.rays;
  return apply_gather(g, u, scene_emission(sys.patches()));
}

// The largest difference between what is got and what is wanted over many entries, and the
// largest wanted.
struct Gap {
  double worst = 0.0, peak = 0.0;
  void add(double got, double want) {
    worst = std::max(worst, std::abs(got - want));
    peak = std::max(peak, std::abs(want));
  }
};

// ---- the penumbra of a square occluder under a square lamp ------------------------------------

// Form factor from a differential area to a parallel rectangle with the normal through one
// corner (papers/glossy-radiosity.md, section 10), odd in a and b, so that any rectangle of the parallel plane is
// a sum of four of them.
double corner_ff(double a, double b, double c) {
  const double A = a / c, B = b / c;
  const double sa = std::sqrt(1 + A * A), sb = std::sqrt(1 + B * B);
  return (A / sa * std::atan(B / sa) + B / sb * std::atan(A / sb)) / (2.0 * kPi);
}
// From the floor point (px, pz) to the rectangle [x0,x1] x [z0,z1] of the plane at height c.
double rectangle_ff(double px, double pz, double x0, double x1, double z0, double z1, double c) {
  if (!(x1 > x0) || !(z1 > z0)) return 0.0;
  return corner_ff(x1 - px, z1 - pz, c) - corner_ff(x0 - px, z1 - pz, c) -
         corner_ff(x1 - px, z0 - pz, c) + corner_ff(x0 - px, z0 - pz, c);
}

// The mean over pixel (x, y) of f at the 16 x 16 points where its rays meet the plane at
// `height` (NaN if f is NaN at any).
template <class F>
double pixel_mean_on_plane(const Camera& cam, int x, int y, double height, F f) {
  double sum = 0.0;
  const int n = 16;
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) {
      const Ray r = cam.ray(x + (a + 0.5) / n, y + (b + 0.5) / n);
      sum += f(r.origin + (height - r.origin.y()) / r.direction.y() * r.direction);
    }
  return sum / (n * n);
}

// A diffuse floor (reflectance 0.5) lit by a 20 x 20 lamp (radiance 10) at height 100, with a
// black 60 x 60 occluder at height 50 whose edge x = 0 lies under the lamp's centre: along z = 0
// the floor is fully lit for x < -10, in penumbra for -10 < x < 10, in umbra beyond. Everything
// but the floor is black, so the floor's radiance is exactly 0.5 * 10 * F_visible(x) / 1, the
// form factor of the part of the lamp the point sees: the lamp minus the occluder projected
// from the point onto the lamp's plane, both rectangles, each summed from corner form factors.
struct Penumbra {
  std::unique_ptr<RadiositySystem> sys;
  SolveResult solution;

  explicit Penumbra(double floor_patch_size) {
    const std::string json = R"({
      "camera": {"position": [0, 30, -60], "look_at": [0, 0, 0], "up": [0, 1, 0],
                 "fov_deg": 9, "width": 64, "height": 16},
      "patch_size": )" + std::to_string(floor_patch_size) +
                             R"(,
      "materials": {
        "black": {"type": "diffuse", "reflectance": [0, 0, 0]},
        "floor": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}
      },
      "objects": [
        {"name": "floor", "material": "floor",
         "polygon": [[100, 0, -100], [-100, 0, -100], [-100, 0, 100], [100, 0, 100]]},
        {"name": "occluder", "material": "black", "patch_size": 60,
         "polygon": [[0, 50, -30], [60, 50, -30], [60, 50, 30], [0, 50, 30]]},
        {"name": "light", "material": "black", "emission": [10, 10, 10], "patch_size": 20,
         "polygon": [[-10, 100, -10], [10, 100, -10], [10, 100, 10], [-10, 100, 10]]}
      ]})";
    sys = build_system(World::build(test::scene_from_json(json)));
    solution = converged(*sys);
  }

  static double exact_radiance(const Vec3& p) {
    const double px = p.x(), pz = p.z();
    // The occluder [0, 60] x [-30, 30] at height 50, seen from (px, 0, pz), on the plane 100.
    const double sx0 = std::max(-10.0, 2 * 0.0 - px), sx1 = std::min(10.0, 2 * 60.0 - px);
    const double sz0 = std::max(-10.0, 2 * -30.0 - pz), sz1 = std::min(10.0, 2 * 30.0 - pz);
    const double visible =
        rectangle_ff(px, pz, -10, 10, -10, 10, 100) - rectangle_ff(px, pz, sx0, sx1, sz0, sz1, 100);
    return 0.5 * 10.0 * visible;
  }

  // The pixel's mean over its area: 16 x 16 points, each the exact radiance where it meets the
  // floor.
  double exact_pixel(int x, int y) const {
    return pixel_mean_on_plane(sys->scene().camera, x, y, 0.0, exact_radiance);
  }
};

TEST(FinalGather, PenumbraMatchesTheVisibleLampPixelByPixel) {
  // Floor patches of 25 against a penumbra 20 wide: the patch gather smears it over one or two
  // patches; the final gather takes the lamp at each pixel.
  Penumbra scene(25.0);
  const int row = 8, width = scene.sys->scene().camera.width;
  GatherOptions flat;
  flat.diffuse = DiffuseMode::kFlat;
  // Finer: 8 x 8 sub-pixel rays with 256 light points each. More light points alone do not do:
  // across the penumbra the radiance changes by a third of its unshadowed value in ten pixels,
  // so 2 x 2 jittered points sample a pixel's area mean only to about 0.3 percent of that value
  // (measured: 2 x 2 rays with 1024 light points, pixels up to 7 percent off their own value).
  GatherOptions many = final_options(16, 256);
  many.pixel_grid = 8;
  const Image patch_image = gather_image(*scene.sys, scene.solution.u, flat);
  const Image standard = gather_image(*scene.sys, scene.solution.u, final_options());
  const Image fine = gather_image(*scene.sys, scene.solution.u, many);
  const double unshadowed = Penumbra::exact_radiance(Vec3(-40, 0, 0));
  double worst_standard = 0.0, worst_fine = 0.0, worst_patch = 0.0;
  int penumbra_pixels = 0;
  for (int x = 0; x < width; ++x) {
    const double exact = scene.exact_pixel(x, row);
    const double a = standard.at(x, row)[0], b = fine.at(x, row)[0], p = patch_image.at(x, row)[0];
    if (exact > 0.05 * unshadowed && exact < 0.95 * unshadowed) ++penumbra_pixels;
    // The default counts (2 x 2 sub-pixel rays, 64 light points each): within 2 percent of the
    // unshadowed radiance at every pixel. Finer: within 2 percent of each pixel's own value
    // wherever it sees a tenth of the lamp or more, and of a tenth of the lamp's value beyond.
    const double own = std::max(exact, 0.1 * unshadowed);
    worst_standard = std::max(worst_standard, std::abs(a - exact) / unshadowed);
    worst_fine = std::max(worst_fine, std::abs(b - exact) / own);
    worst_patch = std::max(worst_patch, std::abs(p - exact) / own);
    EXPECT_LE(std::abs(a - exact), 0.02 * unshadowed)
        << "pixel " << x << ": " << a << ", exact " << exact;
    EXPECT_LE(std::abs(b - exact), 0.02 * own) << "pixel " << x << ": " << b << ", exact " << exact;
  }
  std::printf(
      "penumbra over %d pixels: final gather off by at most %.4f of the unshadowed value "
      "(default counts), %.4f of the pixel's own (finer); patch gather %.4f\n",
      penumbra_pixels, worst_standard, worst_fine, worst_patch);
  EXPECT_GE(penumbra_pixels, 20);
  EXPECT_GT(worst_patch, 10 * 0.02);  // the patch gather misses by far more
}

// ---- the mirror image of a lamp ----------------------------------------------------------------

// At a strip point p (height 150, facing down, reflectance 0.5): 0.5 * 0.9 times the form
// factor of the part of an image [x0, x1] x [-z, z] at height -100 (a surface at height 100 seen
// in the mirror) that lies inside the mirror's [-m, m]^2 at height 0 projected from p onto the
// image's plane (250 / 150 as far): the radiance a unit radiance there sends p through the mirror.
double seen_through_mirror(const Vec3& p, double m, double x0, double x1, double z) {
  const double px = p.x(), pz = p.z(), k = 250.0 / 150.0;
  const double a0 = std::max(x0, px + (-m - px) * k), a1 = std::min(x1, px + (m - px) * k);
  const double b0 = std::max(-z, pz + (-m - pz) * k), b1 = std::min(z, pz + (m - pz) * k);
  return 0.5 * 0.9 * rectangle_ff(px, pz, a0, a1, b0, b1, 250.0);
}

// A 20 x 20 lamp (radiance 10, facing down) at height 100 over a 20 x 20 mirror (reflectance
// 0.9) at height 0, and a strip (reflectance 0.5, facing down) at height 150 above and beside
// both: the strip sees the lamp only from behind (black), and its image, 100 below the mirror,
// only through the mirror's square. A strip point's radiance is then 0.5 * 0.9 * 10 times the
// form factor of the part of the image inside the mirror's square projected from the point onto
// the image's plane (both axis-aligned rectangles), up to the light the strip sends itself
// through the mirror (its own image, 300 away through a 20 x 20 square: under 0.07 percent).
// The projected square's edges move across the strip as fast as the point does, a caustic with
// edges a few units wide that the strip's 25-unit patches cannot hold.
struct MirroredLamp {
  std::unique_ptr<RadiositySystem> sys;
  SolveResult solution;

  explicit MirroredLamp(const SystemOptions& system = {}) {
    const std::string json = R"({
      "camera": {"position": [60, 50, -60], "look_at": [60, 150, 0], "up": [0, 0, 1],
                 "fov_deg": 14, "width": 64, "height": 16},
      "patch_size": 25,
      "materials": {
        "black": {"type": "diffuse", "reflectance": [0, 0, 0]},
        "mirror": {"type": "mirror", "reflectance": [0.9, 0.9, 0.9]},
        "strip": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}
      },
      "objects": [
        {"name": "strip", "material": "strip",
         "polygon": [[0, 150, -10], [100, 150, -10], [100, 150, 10], [0, 150, 10]]},
        {"name": "mirror", "material": "mirror", "patch_size": 20,
         "polygon": [[-10, 0, -10], [-10, 0, 10], [10, 0, 10], [10, 0, -10]]},
        {"name": "light", "material": "black", "emission": [10, 10, 10], "patch_size": 20,
         "polygon": [[-60, 100, -10], [-40, 100, -10], [-40, 100, 10], [-60, 100, 10]]}
      ]})";
    sys = build_system(World::build(test::scene_from_json(json)), system);
    solution = converged(*sys);
  }

  // At a strip point: the image [-60, -40] x [-10, 10] of the lamp (radiance 10) through the
  // mirror's [-10, 10]^2.
  static double exact_radiance(const Vec3& p) {
    return 10.0 * seen_through_mirror(p, 10.0, -60.0, -40.0, 10.0);
  }

  // The pixel's mean where it meets the strip; NaN if any of its points misses it.
  double exact_pixel(int x, int y) const {
    return pixel_mean_on_plane(sys->scene().camera, x, y, 150.0, [](const Vec3& p) {
      return p.x() < 0 || p.x() > 100 || std::abs(p.z()) > 10 ? NAN : exact_radiance(p);
    });
  }
};

// Every pixel of the strip against the exact caustic, with the images, with the links alone and
// with the samples followed through the mirror alone; the worst errors as fractions of the peak.
void expect_mirrored_lamp(const SystemOptions& system, const char* mesh) {
  MirroredLamp scene(system);
  const Camera& cam = scene.sys->scene().camera;
  GatherOptions images = final_options(), links = final_options(), through = final_options();
  images.mirror_image_samples = 1024;  // the caustic's edges, not the images' noise, under test
  links.mirror_image_samples = through.mirror_image_samples = 0;
  links.through_mirrors = ThroughMirrors::kNever;
  through.through_mirrors = ThroughMirrors::kAlways;
  // Through the mirror the lamp is found by the reflector points (and the rare cosine sample)
  // alone: enough of them that their noise stays under the tolerance.
  through.reflector_samples = 4096;
  const Image with = gather_image(*scene.sys, scene.solution.u, images);
  const Image without = gather_image(*scene.sys, scene.solution.u, links);
  const Image traced = gather_image(*scene.sys, scene.solution.u, through);
  Gap images_gap, links_gap, through_gap;
  int pixels = 0, lit = 0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      const double exact = scene.exact_pixel(x, y);
      if (std::isnan(exact)) continue;
      ++pixels;
      lit += exact > 0.0;
      const std::size_t k = 3 * (static_cast<std::size_t>(y) * cam.width + x);
      images_gap.add(with.rgb[k], exact);
      links_gap.add(without.rgb[k], exact);
      through_gap.add(traced.rgb[k], exact);
    }
  const double peak = images_gap.peak, worst_images = images_gap.worst;
  const double worst_links = links_gap.worst, worst_through = through_gap.worst;
  std::printf(
      "mirrored lamp (%s, %d B unknowns) over %d strip pixels (%d lit), peak %.5f: images off "
      "by at most %.4f of the peak, the links alone %.4f, through the mirror alone %.4f\n",
      mesh, scene.sys->transport.num_patches(), pixels, lit, peak, worst_images / peak,
      worst_links / peak, worst_through / peak);
  ASSERT_GE(pixels, 200);
  EXPECT_GE(lit, 100);
  EXPECT_LE(worst_images, 0.02 * peak) << mesh;
  EXPECT_GT(worst_links, 0.1 * peak) << mesh;  // the links spread it over the strip's patches
  EXPECT_LE(worst_through, 0.03 * peak) << mesh;
}

TEST(FinalGather, MirrorImagesMatchTheMirroredLampPixelByPixel) {
  expect_mirrored_lamp({}, "uniform");
  // The hierarchy's mirror links run between roots, and MeshDirect takes the lamp's share out
  // of them through the hierarchical operator (eq. H3's rows): the same errors to four digits,
  // since the strip's light is that link on both meshes (its trees refined to 15 leaves at tau
  // 0.005 change only what little it sends itself).
  SystemOptions hierarchical;
  hierarchical.mesh = MeshKind::kHierarchical;
  hierarchical.hierarchy.link_tolerance = 0.005;
  expect_mirrored_lamp(hierarchical, "hierarchical");
}

// A strip (reflectance 0.5, facing down) at height 150 over a 60 x 60 mirror (0.9) at height 0,
// and beside both a lit card (one 60 x 60 patch, reflectance 0.8, facing down) at height 100 with
// the lamp beside and below it, turned away from the strip and the mirror (its black back hides
// nothing the strip sees through the mirror). The strip sees the card only through the mirror, so
// a strip point's radiance is 0.5 * 0.9 * L_card times the form factor of the card's image (100
// below the mirror) inside the mirror's outline projected from the point (as MirroredLamp),
// L_card the card's one B, read flat as the gather reads it: what a sample through the mirror
// reads where the images give the lamps' light, against the mirror's link, one value over each
// strip patch.
struct MirroredCard {
  std::unique_ptr<RadiositySystem> sys;
  SolveResult solution;
  double card = 0.0;  // the card's radiance, from the solution (first channel)

  MirroredCard() {
    const std::string json = R"({
      "camera": {"position": [60, 50, -60], "look_at": [60, 150, 0], "up": [0, 0, 1],
                 "fov_deg": 14, "width": 64, "height": 16},
      "patch_size": 25,
      "materials": {
        "black": {"type": "diffuse", "reflectance": [0, 0, 0]},
        "mirror": {"type": "mirror", "reflectance": [0.9, 0.9, 0.9]},
        "strip": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]},
        "card": {"type": "diffuse", "reflectance": [0.8, 0.8, 0.8]}
      },
      "objects": [
        {"name": "strip", "material": "strip",
         "polygon": [[0, 150, -10], [100, 150, -10], [100, 150, 10], [0, 150, 10]]},
        {"name": "mirror", "material": "mirror", "patch_size": 60,
         "polygon": [[-30, 0, -30], [-30, 0, 30], [30, 0, 30], [30, 0, -30]]},
        {"name": "card", "material": "card", "patch_size": 90,
         "polygon": [[-90, 100, -30], [-30, 100, -30], [-30, 100, 30], [-90, 100, 30]]},
        {"name": "light", "material": "black", "emission": [10, 10, 10], "patch_size": 90,
         "polygon": [[-21.177, 85.617, 30], [-18.823, 97.383, 30], [-18.823, 97.383, -30],
                     [-21.177, 85.617, -30]]}
      ]})";
    sys = build_system(World::build(test::scene_from_json(json)));
    solution = converged(*sys);
    const Scene& scene = sys->scene();
    int cards = 0;
    for (std::size_t p = 0; p < sys->patches().size(); ++p)
      if (scene.objects[sys->patches()[p].object].name == "card") {
        card = solution.u(static_cast<Eigen::Index>(p), 0);
        ++cards;
      }
    EXPECT_EQ(cards, 1);
  }

  // At a strip point: the card's image [-90, -30] x [-30, 30] through the mirror's [-30, 30]^2.
  double exact_radiance(const Vec3& p) const {
    return card * seen_through_mirror(p, 30.0, -90.0, -30.0, 30.0);
  }
  double exact_pixel(int x, int y) const {
    return pixel_mean_on_plane(sys->scene().camera, x, y, 150.0, [this](const Vec3& p) {
      return p.x() < 0 || p.x() > 100 || std::abs(p.z()) > 10 ? NAN : exact_radiance(p);
    });
  }
};

TEST(FinalGather, ThroughTheMirrorTheCardLightsTheStripPixelByPixel) {
  MirroredCard scene;
  ASSERT_GT(scene.card, 0.0);
  const Camera& cam = scene.sys->scene().camera;
  // No reflector points are drawn on a mirror whose images are: the cosine samples alone find
  // the card through it, so many of them, at 4 x 4 points a pixel (the exact value is the
  // pixel's mean). Off by at most 1.6 percent of the peak so; 4.3 with a quarter of the cosine
  // samples, 5.3 with them at 2 x 2 points: the samples' noise and the pixel's, not a bias.
  GatherOptions through = final_options(4096), links = final_options(4096);
  through.pixel_grid = links.pixel_grid = 4;
  links.through_mirrors = ThroughMirrors::kNever;
  const Image read_through = gather_image(*scene.sys, scene.solution.u, through);
  const Image read_links = gather_image(*scene.sys, scene.solution.u, links);
  Gap through_gap, links_gap;
  int pixels = 0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      const double exact = scene.exact_pixel(x, y);
      if (std::isnan(exact)) continue;
      ++pixels;
      const std::size_t k = 3 * (static_cast<std::size_t>(y) * cam.width + x);
      through_gap.add(read_through.rgb[k], exact);
      links_gap.add(read_links.rgb[k], exact);
    }
  const double peak = through_gap.peak;
  std::printf(
      "mirrored card (radiance %.5f) over %d strip pixels, peak %.6f: through the mirror "
      "off by at most %.4f of the peak, its links %.4f\n",
      scene.card, pixels, peak, through_gap.worst / peak, links_gap.worst / peak);
  ASSERT_GE(pixels, 200);
  EXPECT_LE(through_gap.worst, 0.03 * peak);
  EXPECT_GT(links_gap.worst, 0.2 * peak);  // the link is one value over each strip patch
}

// Between facing mirrors the floor sees the lamp through up to tens of mirrors
// (test::facing_mirrors_black(), where its radiance is exactly a sum over the lamp's images). The
// mesh's links between the mirrors forget where the light met each, so its light strays (the
// floor's patches 5.6 percent dark); drawn at its images through up to mirror_image_depth
// mirrors, the lamp lights each pixel as the sum says: the 64 pixels' mean -4.4 percent through
// one mirror (its worst pixel 24), -0.05 through up to 32 (0.5), measured; the tail past the
// depth is left on the links.
TEST(FinalGather, FacingMirrorsLightTheFloorThroughTheLampsImagesPixelByPixel) {
  const auto sys = build_system(World::build(test::facing_mirrors_black()));
  const SolveResult solution = converged(*sys);
  const Camera& cam = sys->scene().camera;
  std::vector<double> exact;
  double exact_sum = 0.0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      exact.push_back(pixel_mean_on_plane(cam, x, y, 0.0, test::facing_mirrors_floor_radiance));
      exact_sum += exact.back();
    }
  const auto mean_error = [&](int depth, double& worst) {
    GatherOptions o = final_options();
    o.mirror_image_depth = depth;
    const Image image = gather_image(*sys, solution.u, o);
    double sum = 0.0;
    worst = 0.0;
    for (std::size_t k = 0; k < exact.size(); ++k) {
      sum += image.rgb[3 * k + 1];
      worst = std::max(worst, std::abs(image.rgb[3 * k + 1] / exact[k] - 1.0));
    }
    return sum / exact_sum - 1.0;
  };
  double worst_one = 0.0, worst_deep = 0.0;
  const double one = mean_error(1, worst_one), deep = mean_error(32, worst_deep);
  std::printf(
      "facing mirrors' floor against the sum over the lamp's images: through one mirror %+.2f%% "
      "(worst pixel %.2f%%), through up to 32 %+.2f%% (worst pixel %.2f%%)\n",
      100.0 * one, 100.0 * worst_one, 100.0 * deep, 100.0 * worst_deep);
  EXPECT_LT(one, -0.04);  // the links' stray light, which the test must be able to see
  EXPECT_LT(std::abs(deep), 0.005);
  EXPECT_LT(worst_deep, 0.02);
}

// The mirrored room (test::mirrored_room: four mirror walls of 0.9, each facing the other three,
// a white floor seen from above, a lamp in the black ceiling), whose floor's radiance is the sum
// over the lattice of the lamp's images through the walls. The chains
// of images are those whose beam is not empty (transport/mirror_chains.h), kept whole lengths
// at a time within a budget: every sequence of walls would be 3^n of them (trying each made a
// gather of three facing mirrors 900 times slower at depth 16), the beams leave 4, 12, 24, 40
// ... (MirrorChains.EveryPathARayTakesIsAChainKeptAndNoOther). Measured: the floor's mean -10.2
// percent through one wall; at depth 16 and budgets 64, 256 and 1024 -2.75, -0.69 and -0.07,
// for 2.1, 3.3 and 5.2 times its rays.
TEST(FinalGather, MirroredRoomDrawsItsChainsThroughEveryWall) {
  const auto sys = build_system(World::build(test::mirrored_room()));
  const SolveResult solution = converged(*sys);
  const Camera& cam = sys->scene().camera;
  double exact = 0.0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      const Ray r = cam.ray(x + 0.5, y + 0.5);
      exact += test::mirrored_room_floor_radiance(r.origin -
                                                  r.origin.y() / r.direction.y() * r.direction);
    }
  exact /= cam.width * cam.height;
  const auto run = [&](int depth, int budget, long long& rays) {
    GatherOptions o = final_options();
    o.mirror_image_depth = depth;
    o.mirror_chain_budget = budget;
    const Image image = gather_image(*sys, solution.u, o, &rays);
    double sum = 0.0;
    for (std::size_t k = 0; k < image.rgb.size(); k += 3) sum += image.rgb[k + 1];
    return sum / (cam.width * cam.height) / exact - 1.0;
  };
  const int budget = GatherOptions{}.mirror_chain_budget;
  long long rays1 = 0, rays64 = 0, rays = 0, rays1024 = 0;
  const double one = run(1, budget, rays1), some = run(16, 64, rays64),
               kept = run(16, budget, rays), more = run(16, 1024, rays1024);
  std::printf(
      "mirrored room's floor against the lattice of images: one wall %+.2f%% (%lld rays); "
      "chains of up to 16 walls, budget 64 %+.2f%% (%lld), %d %+.2f%% (%lld), 1024 %+.2f%% "
      "(%lld)\n",
      100 * one, rays1, 100 * some, rays64, budget, 100 * kept, rays, 100 * more, rays1024);
  EXPECT_LT(one, -0.05);  // the links' stray light, which the chains take back
  EXPECT_LT(std::abs(kept), 0.015);
  EXPECT_LT(std::abs(more), std::abs(kept));  // the chains carry the light, more of them more
  EXPECT_LT(std::abs(kept), std::abs(some));
  EXPECT_LT(rays, 4 * rays1);  // the beams: rays only for light points a chain can show
}

// A mirror with a diffuse part passes chains on as well as it begins them: the lamps' images
// through it, and its own reflected light read where a sample's path meets it on the way. The
// mirrored room with its west wall a mirror of 0.8 over a diffuse 0.1, against the path tracer
// (8,192 paths a pixel; the image mean's relative standard error about 0.7 percent). Measured:
// one mirror -9.6 percent, the chains -0.5; -4.5 when chains stopped at such a wall unless it
// came first.
TEST(FinalGather, ChainsPassAMirrorWithADiffusePart) {
  std::string text = test::read_text(test::scene_path("stability/mirrored-room"));
  const std::string west = "{\"name\": \"west\", \"material\": \"mirror\"";
  ASSERT_NE(text.find(west), std::string::npos);
  text.replace(text.find(west), west.size(), "{\"name\": \"west\", \"material\": \"part\"");
  const std::string materials = "\"materials\": {";
  text.replace(text.find(materials), materials.size(),
               materials + R"("part": {"type": "glossy", "diffuse": [0.1, 0.1, 0.1],
                                     "specular": [0.8, 0.8, 0.8], "roughness": 0},)");
  Scene scene = test::scene_from_json(text);
  scene.camera.width = scene.camera.height = 8;
  const auto sys = build_system(World::build(std::move(scene)));
  const SolveResult solution = converged(*sys);
  const auto mean = [](const Image& image) {
    double sum = 0.0;
    for (std::size_t k = 0; k < image.rgb.size(); k += 3) sum += image.rgb[k + 1];
    return sum / static_cast<double>(image.rgb.size() / 3);
  };
  PathTraceOptions po;
  po.spp = test::kUnderAddressSanitizer ? 2048 : 8192;
  po.max_depth = 200;
  po.progress = false;
  const double traced = mean(PathTracer(*sys->world).render(sys->world->camera(), po).image);
  GatherOptions one = final_options();
  one.mirror_image_depth = 1;
  const double through_one = mean(gather_image(*sys, solution.u, one)) / traced - 1.0;
  const double chained = mean(gather_image(*sys, solution.u, final_options())) / traced - 1.0;
  std::printf("a mirror wall with a diffuse part: one mirror %+.2f%%, chains %+.2f%%\n",
              100 * through_one, 100 * chained);
  EXPECT_LT(through_one, -0.05);
  EXPECT_LT(std::abs(chained), test::kUnderAddressSanitizer ? 0.03 : 0.02);
}

// The gather counts the hits before facing mirrors and those where the budget cut the chains
// short (reported, and a warning at 1 percent of the hits or more): on the mirrored room's floor
// a budget of 64 keeps every chain of up to 3 walls and cuts there at every hit; a budget that
// holds every chain of up to 3 cuts none; one mirror builds no chains.
TEST(FinalGather, CountsTheHitsWhereTheBudgetCutTheChains) {
  const auto sys = build_system(World::build(test::mirrored_room()));
  const auto count = [&](int depth, int budget) {
    GatherOptions o = final_options();
    o.light_samples = o.gather_samples = 4;
    o.mirror_image_depth = depth;
    o.mirror_chain_budget = budget;
    const auto direct = mesh_direct_for(o, sys->transport, *sys->world);
    return build_gather(*sys->world, sys->transport.layout(), o, direct.get()).mirror_chains;
  };
  const MirrorChainCount cut = count(16, 64), whole = count(3, 100000), none = count(1, 64);
  EXPECT_GT(cut.hits, 0);
  EXPECT_EQ(cut.cut, cut.hits);
  EXPECT_EQ(cut.shortest_cut, 3);
  EXPECT_EQ(whole.hits, cut.hits);  // the same shading rays, whatever the chains
  EXPECT_EQ(whole.cut, 0);
  EXPECT_EQ(whole.shortest_cut, 0);
  EXPECT_EQ(none.hits, 0);
}

// ---- furnaces: E / (1 - a) at every pixel ------------------------------------------------------

// A diffuse or mirror material of reflectance a.
std::string grey(const char* type, double a) {
  std::ostringstream s;
  s << "{\"type\": \"" << type << "\", \"reflectance\": [" << a << ", " << a << ", " << a << "]}";
  return s.str();
}
// Lambert plus a mirror (GGX below the delta roughness): albedo d + s for every direction.
std::string lambert_plus_mirror(double d, double s) {
  std::ostringstream o;
  o << "{\"type\": \"glossy\", \"diffuse\": [" << d << ", " << d << ", " << d
    << "], \"specular\": [" << s << ", " << s << ", " << s << "], \"roughness\": 0}";
  return o.str();
}

// Every pixel of a closed box whose every face emits 1 with albedo a reads 1 / (1 - a) within
// half a percent: emission read twice (once by the light points, again through B) would give
// 1 / (1 - a) + a, a bounce lost 1 / (1 - a) - a^n / (1 - a) at best. Sample counts well above
// the defaults, so that the noise of the MIS-weighted direct light stays well under the
// tolerance at every pixel (measured with the defaults: a spread of about +-1 percent, without
// bias); the image's mean, where that noise averages out, within 0.05 percent.
// With the indirect light from the mesh, the light points alone take the direct light: 256 of
// them, for the same reason.
// No mirror images unless asked (mirror_images): a read of a mirror's link then brings all of
// its light, as much as any other direction's, so the cosine samples see a flat field; with the
// images a mirror's direction reads only what its lamps' images do not give (below): through
// the mirror, or with `through` kNever its link less the lamps' part.
void expect_furnace(const std::vector<std::string>& faces, double a, int near_samples = 4,
                    DiffuseMode reads = DiffuseMode::kFlat, const SystemOptions& system = {},
                    int reflector_samples = GatherOptions::final_gather().reflector_samples,
                    IndirectMode indirect = IndirectMode::kRays, int mirror_images = 0,
                    int gather_samples = 256, double pixel_tolerance = 5e-3,
                    double mesh_near_distance = 0.0, int mesh_near_samples = 0,
                    ThroughMirrors through = ThroughMirrors::kImaged) {
  Scene scene = test::scene_from_json(test::closed_box_json(Vec3(1, 1.2, 0.9), 0.3, faces, 1.0));
  // Every pixel is checked: 256 are enough. Under the sanitizers, which look for memory errors
  // in the same code, 64 (each furnace here holds at 8 x 8 in Release too).
  scene.camera.width = scene.camera.height = test::kUnderAddressSanitizer ? 8 : 16;
  auto sys = build_system(World::build(std::move(scene)), system);
  SolveResult r = converged(*sys);
  GatherOptions o = final_options(gather_samples, indirect == IndirectMode::kMesh ? 256 : 64);
  o.near_samples = near_samples;
  o.diffuse = reads;
  o.mesh_read = reads;
  o.reflector_samples = reflector_samples;
  o.mirror_image_samples = mirror_images;
  o.indirect = indirect;
  o.mesh_near_distance = mesh_near_distance;
  o.mesh_near_samples = mesh_near_samples > 0 ? mesh_near_samples : gather_samples;
  o.through_mirrors = through;
  Image img = gather_image(*sys, r.u, o);
  const double exact = 1.0 / (1.0 - a);
  double lo = INFINITY, hi = 0.0, mean = 0.0;
  for (size_t k = 0; k < img.rgb.size(); ++k) {
    lo = std::min(lo, static_cast<double>(img.rgb[k]));
    hi = std::max(hi, static_cast<double>(img.rgb[k]));
    mean += img.rgb[k] / static_cast<double>(img.rgb.size());
    ASSERT_NEAR(img.rgb[k], exact, pixel_tolerance * exact)
        << "pixel " << k / 3 << " channel " << k % 3;
  }
  EXPECT_NEAR(mean, exact, 5e-4 * exact);
  std::printf("furnace at albedo %.2f: pixels in [%.5f, %.5f], mean %.5f, exact %.5f\n", a, lo, hi,
              mean, exact);
}

TEST(FinalGather, DiffuseFurnaceReadsEmissionOverOneMinusAlbedo) {
  expect_furnace(std::vector<std::string>(6, grey("diffuse", 0.5)), 0.5);
  expect_furnace(std::vector<std::string>(6, grey("diffuse", 0.8)), 0.8);
}

TEST(FinalGather, MirrorFurnaceReadsEmissionOverOneMinusAlbedo) {
  expect_furnace(std::vector<std::string>(6, grey("mirror", 0.5)), 0.5);
}

TEST(FinalGather, FurnaceHoldsThroughMirrors) {
  // Samples that meet a mirror read what it shows, Le there included where no image gives it
  // (read twice, the mirror's link and what it shows, the box would read 1 / (1 - a) plus the
  // mirrors' share; the emission left out, less by it).
  const std::vector<std::string> mixed = {
      grey("diffuse", 0.6), grey("mirror", 0.6),  lambert_plus_mirror(0.3, 0.3),
      grey("mirror", 0.6),  grey("diffuse", 0.6), lambert_plus_mirror(0.2, 0.4)};
  expect_furnace(mixed, 0.6, 4, DiffuseMode::kFlat, {}, 64, IndirectMode::kRays, 0, 256, 5e-3, 0.0,
                 0, ThroughMirrors::kAlways);
}

TEST(FinalGather, GlossyMixFurnaceReadsEmissionOverOneMinusAlbedo) {
  // Lambert plus mirror on every face, and the faces mixed: diffuse, mirror and both.
  expect_furnace(std::vector<std::string>(6, lambert_plus_mirror(0.3, 0.4)), 0.7);
  expect_furnace({grey("diffuse", 0.6), grey("mirror", 0.6), lambert_plus_mirror(0.3, 0.3),
                  grey("mirror", 0.6), grey("diffuse", 0.6), lambert_plus_mirror(0.2, 0.4)},
                 0.6);
}

TEST(FinalGather, FurnaceHoldsWithoutTheSecondGather) {
  // The near hits' second gather is a different estimator of the same reflected light.
  expect_furnace(std::vector<std::string>(6, grey("diffuse", 0.5)), 0.5, 0);
}

TEST(FinalGather, FurnaceHoldsWithSmoothReads) {
  // B~ - E~ interpolated alike: the emission part subtracts what the smooth B read added.
  expect_furnace(std::vector<std::string>(6, grey("diffuse", 0.5)), 0.5, 4, DiffuseMode::kSmooth);
  expect_furnace({grey("diffuse", 0.6), grey("mirror", 0.6), lambert_plus_mirror(0.3, 0.3),
                  grey("mirror", 0.6), grey("diffuse", 0.6), lambert_plus_mirror(0.2, 0.4)},
                 0.6, 4, DiffuseMode::kSmooth);
}

TEST(FinalGather, FurnaceHoldsWithoutReflectorPoints) {
  // The furnaces above draw the default points on the reflectors, whose links they and the
  // cosine samples read, weighted by the power heuristic (counted twice, the mixed furnace would
  // give 1 / (1 - a) plus the links' share). The cosine samples alone hold it too.
  expect_furnace({grey("diffuse", 0.6), grey("mirror", 0.6), lambert_plus_mirror(0.3, 0.3),
                  grey("mirror", 0.6), grey("diffuse", 0.6), lambert_plus_mirror(0.2, 0.4)},
                 0.6, 4, DiffuseMode::kFlat, {}, 0);
}

// A scene on a coarse mesh (patch size 100), seen at 24 x 24 pixels, and its solution.
struct SolvedView {
  std::unique_ptr<RadiositySystem> sys;
  SolveResult solution;
};
SolvedView coarse_small_view(const std::string& name, double patch_size = 100, int size = 24) {
  Scene scene = load_scene(test::scene_path(name));
  scene.camera.width = scene.camera.height = size;
  SceneOverrides coarse;
  coarse.patch_size = patch_size;
  SolvedView v{build_system(World::build(std::move(scene), coarse)), {}};
  v.solution = converged(*v.sys);
  return v;
}

// The mirror cube's diffuse surfaces read the mirror's bright, patch-to-patch changing links:
// points on the reflectors bring the 64 cosine samples' image nearer the limit they tend to
// (the same gather with 1024 cosine samples, on the same solution).
TEST(FinalGather, ReflectorPointsLowerTheNoiseOfTheMirrorsLight) {
  const SolvedView v = coarse_small_view("cornell-mirror-cube");
  const RadiositySystem* sys = v.sys.get();
  const SolveResult& r = v.solution;
  GatherOptions alone = final_options(), limit_options = final_options(1024);
  alone.reflector_samples = limit_options.reflector_samples = 0;
  // The links read whole: without the mirror images they hold the lamp's light too (with them,
  // 0.0323 and 0.0326: the links that are left change too little from patch to patch to gain).
  alone.mirror_image_samples = limit_options.mirror_image_samples = 0;
  const Image limit = gather_image(*sys, r.u, limit_options);
  GatherOptions with = final_options();
  with.reflector_samples = 64;
  with.mirror_image_samples = 0;
  const double cosine_alone = compare_images(gather_image(*sys, r.u, alone), limit).relative_rmse;
  const double with_points = compare_images(gather_image(*sys, r.u, with), limit).relative_rmse;
  std::printf("against 1024 cosine samples: 64 cosine samples %.4f, with 64 reflector points %.4f\n",
              cosine_alone, with_points);
  EXPECT_LT(with_points, 0.8 * cosine_alone);
}

// The lamps' light that one mirror reflects, taken at each point from the lamps' images and
// left out where the diffuse part reads a mirror: of the mirrors' links (`never`; counted twice,
// the links read whole, the mixed box reads 7.4 percent bright on average, pixels up to 12;
// left out, no images, 7.4 percent dark), or of what the samples read through the mirror (the
// default). Reading a mirror then no longer brings as much as any other direction (its images
// bring the rest), so the cosine samples see a field that is not flat and the images carry
// their own noise: four times the cosine samples and 4096 images for the half percent at every
// pixel (links at 256 and 1024: pixels from -0.7 to +0.5 percent, the image's mean within
// 1e-4; through the mirrors -0.4 to +0.3).
TEST(FinalGather, FurnaceHoldsWithMirrorImages) {
  const std::vector<std::string> mixed = {
      grey("diffuse", 0.6), grey("mirror", 0.6),  lambert_plus_mirror(0.3, 0.3),
      grey("mirror", 0.6),  grey("diffuse", 0.6), lambert_plus_mirror(0.2, 0.4)};
  expect_furnace(mixed, 0.6, 4, DiffuseMode::kFlat, {}, 0, IndirectMode::kRays, 4096, 1024);
  expect_furnace(mixed, 0.6, 4, DiffuseMode::kFlat, {}, 0, IndirectMode::kRays, 4096, 1024, 5e-3,
                 0.0, 0, ThroughMirrors::kNever);
  // With the indirect light from the mesh, the read of the unknown under x leaves out what the
  // mirrors' links brought it of the lamps' light (render/mesh_direct.h). That read is the
  // patch's mean, the images' light the point's own, which changes over the patch with the
  // mirror's solid angle: pixels from -1.7 to +1.3 percent, the same with four times the
  // images (not their noise), while the image's mean, where each patch's mean is what is
  // left out, holds to 0.05 percent (+0.02).
  expect_furnace(mixed, 0.6, 4, DiffuseMode::kFlat, {}, 0, IndirectMode::kMesh, 4096, 256, 2e-2);
}

TEST(FinalGather, FurnacesHoldOnTheHierarchicalMesh) {
  // The gather reads the leaves under each hit (B) and the root links (S, eq. H3). A tight link
  // tolerance, so that the leaves themselves hold E / (1 - a) to well under the half percent
  // (at the default 0.05 the links' form factors leave them about half a percent low:
  // Hierarchy.FurnaceIsEmissionOverOneMinusAlbedoOnEveryLeaf).
  SystemOptions hierarchical;
  hierarchical.mesh = MeshKind::kHierarchical;
  hierarchical.hierarchy.link_tolerance = 0.01;
  hierarchical.hierarchy.min_element_size = 0.3 / 8;
  expect_furnace({grey("diffuse", 0.6), grey("mirror", 0.6), lambert_plus_mirror(0.3, 0.3),
                  grey("mirror", 0.6), grey("diffuse", 0.6), lambert_plus_mirror(0.2, 0.4)},
                 0.6, 4, DiffuseMode::kFlat, hierarchical);
}

// The indirect light read from the unknown under each hit, B - E - D e (render/mesh_direct.h),
// with the direct light from the light points: the direct light counted twice would give
// 1 / (1 - a) + a, left out 1 / (1 - a) - a. Flat and smooth reads, diffuse, mirror and mixed
// faces, on both meshes.
TEST(FinalGather, FurnacesHoldWithTheIndirectLightFromTheMesh) {
  const std::vector<std::string> mixed = {
      grey("diffuse", 0.6), grey("mirror", 0.6),  lambert_plus_mirror(0.3, 0.3),
      grey("mirror", 0.6),  grey("diffuse", 0.6), lambert_plus_mirror(0.2, 0.4)};
  const IndirectMode mesh = IndirectMode::kMesh;
  expect_furnace(std::vector<std::string>(6, grey("diffuse", 0.5)), 0.5, 4, DiffuseMode::kFlat, {},
                 0, mesh);
  expect_furnace(mixed, 0.6, 4, DiffuseMode::kFlat, {}, 0, mesh);
  expect_furnace(mixed, 0.6, 4, DiffuseMode::kSmooth, {}, 0, mesh);
  // Each pixel reads one leaf, whose own error it keeps (at 0.01 and three levels a leaf 0.7
  // percent bright): tighter than FurnacesHoldOnTheHierarchicalMesh, as the patch gather would
  // need, on two levels (three at 0.003 held as well, in four times the time: 312 s under the
  // sanitizers).
  SystemOptions hierarchical;
  hierarchical.mesh = MeshKind::kHierarchical;
  hierarchical.hierarchy.link_tolerance = 0.005;
  hierarchical.hierarchy.min_element_size = 0.3 / 4;
  expect_furnace(mixed, 0.6, 4, DiffuseMode::kFlat, hierarchical, 0, mesh);
}

// Points near a surface gathered by rays, the rest read from the mesh, in one image: at half a
// patch diameter the 0.3 patches of the box put about half the shading points on each side
// (52 percent on the diffuse box). The near points draw four times the cosine samples of the
// others, and their light points must weigh the lights against that count (against the
// others' count, the image is off by several percent: every face is a light here). With the
// mirror images (the mesh mode's default where a scene has mirrors), a near point's reads of a
// mirror's links leave out the lamps' light the images gave (read whole: 4.3 percent bright),
// within 2 percent per pixel as the mesh mode's own furnace with images (above); and with
// points on the reflectors, which the near points draw when asked.
TEST(FinalGather, FurnacesHoldWithTheMeshsNearPointsGatheredByRays) {
  const std::vector<std::string> mixed = {
      grey("diffuse", 0.6), grey("mirror", 0.6),  lambert_plus_mirror(0.3, 0.3),
      grey("mirror", 0.6),  grey("diffuse", 0.6), lambert_plus_mirror(0.2, 0.4)};
  const IndirectMode mesh = IndirectMode::kMesh;
  expect_furnace(std::vector<std::string>(6, grey("diffuse", 0.5)), 0.5, 4, DiffuseMode::kFlat, {},
                 0, mesh, 0, 256, 5e-3, 0.5, 1024);
  expect_furnace(mixed, 0.6, 4, DiffuseMode::kFlat, {}, 0, mesh, 0, 256, 5e-3, 0.5, 1024);
  expect_furnace(mixed, 0.6, 4, DiffuseMode::kFlat, {}, 0, mesh, 4096, 256, 2e-2, 0.5, 1024);
  expect_furnace(mixed, 0.6, 4, DiffuseMode::kFlat, {}, 0, mesh, 4096, 256, 2e-2, 0.5, 1024,
                 ThroughMirrors::kNever);
  expect_furnace(mixed, 0.6, 4, DiffuseMode::kFlat, {}, 64, mesh, 0, 256, 5e-3, 0.5, 1024);
}

// The unknown under a point is the mean of its light, which near a corner changes across it:
// on cornell-box's coarse mesh (patch size 100) the mesh's reads are off along every edge of
// the box and the blocks. Gathered by rays within two diameters of a surface, the image comes
// near to the rays' own limit (1024 cosine samples at every point, on the same solution).
TEST(FinalGather, MeshsNearPointsGatheredByRaysComeNearTheRays) {
  const SolvedView v = coarse_small_view("cornell-box");
  const RadiositySystem* sys = v.sys.get();
  const SolveResult& r = v.solution;
  GatherOptions limit = final_options(1024),
                read = GatherOptions::final_gather(IndirectMode::kMesh);
  limit.reflector_samples = 0;
  read.mesh_read = DiffuseMode::kFlat;
  const Image reference = gather_image(*sys, r.u, limit);
  const double near = compare_images(gather_image(*sys, r.u, read), reference).relative_rmse;
  read.mesh_near_distance = 0.0;
  const double everywhere = compare_images(gather_image(*sys, r.u, read), reference).relative_rmse;
  std::printf(
      "against 1024 cosine samples: the mesh read everywhere %.4f, rays near surfaces %.4f\n",
      everywhere, near);
  EXPECT_LT(near, 0.5 * everywhere);
}

// Away from surfaces the light still changes across an unknown: at the scene's own patch size
// (50), read smooth (the default), in the averages at the corners, the mesh comes nearer to the
// rays' limit than each patch's mean where the points near surfaces are gathered by rays (the
// default). Read everywhere it does not (printed, 0.0823 against 0.0776): by a contact the
// corners' averages spread the light of one side to the other. Nor on a small image, whose
// pixel covers much of a patch and whose mean the flat read keeps, nor on patches twice the
// size (README, "Smooth reads of the mesh"). With --diffuse smooth, mesh_read flat still reads
// the point flat.
TEST(FinalGather, MeshReadSmoothComesNearerTheRaysThanItsMeans) {
  // Under the sanitizers, which look for memory errors in the same code, a 16 x 16 image, its
  // figures checked in Release only.
  const bool light = test::kUnderAddressSanitizer;
  const SolvedView v = coarse_small_view("cornell-box", 50, light ? 16 : 64);
  const RadiositySystem* sys = v.sys.get();
  GatherOptions limit = final_options(light ? 16 : 1024),
                smooth = GatherOptions::final_gather(IndirectMode::kMesh);
  limit.reflector_samples = 0;
  ASSERT_EQ(smooth.mesh_read, DiffuseMode::kSmooth);
  const Image reference = gather_image(*sys, v.solution.u, limit);
  auto error = [&](const GatherOptions& o) {
    return compare_images(gather_image(*sys, v.solution.u, o), reference).relative_rmse;
  };
  GatherOptions flat = smooth;
  flat.mesh_read = DiffuseMode::kFlat;
  const double near = error(smooth), near_flat = error(flat);
  smooth.mesh_near_distance = flat.mesh_near_distance = 0.0;
  const double everywhere = error(smooth), everywhere_flat = error(flat);
  std::printf(
      "against %d cosine samples: smooth %.4f (the mesh read everywhere %.4f), flat %.4f (%.4f)\n",
      limit.gather_samples, near, everywhere, near_flat, everywhere_flat);
  if (light) return;
  EXPECT_LT(near, near_flat);
  GatherOptions both = flat;
  both.diffuse = DiffuseMode::kSmooth;  // the gather samples' reads only
  smooth.diffuse = DiffuseMode::kSmooth;
  EXPECT_NE(error(both), error(smooth));
}

// On a hierarchy the probes reach at least half the root's diameter, however fine the leaf: a
// leaf's light from the many sources that each bring it little comes on links at or near its
// root, and a surface within the root's size shadows a part of it that those links cannot
// follow. The room on 1 m roots (45,000 leaves), against a 1024-sample rays gather of the same
// solution: with the leaf's own diameter the north wall's region read 6.8 percent dark, the
// west wall's 3.0, relative RMSE 0.056 (the mesh read everywhere: 7.0, 3.5, 0.069); with half
// the root's, 0.9, 1.1 and 0.042.
TEST(FinalGather, MeshsNearPointsOnAHierarchyReachAsOnItsRoots) {
  // Under the sanitizers, which look for memory errors in the same code, cornell-box's coarse
  // hierarchy and a small image, its figures checked in Release only (the room would take about
  // ten minutes there).
  const bool light = test::kUnderAddressSanitizer;
  Scene scene = load_scene(test::scene_path(light ? "cornell-box" : "room"));
  scene.camera.width = light ? 16 : 40;
  scene.camera.height = light ? 16 : 30;
  SceneOverrides coarse;
  coarse.patch_size = light ? 100 : 1000;
  SystemOptions so;
  so.mesh = MeshKind::kHierarchical;
  so.hierarchy.link_tolerance = 0.05;
  auto sys = build_system(World::build(std::move(scene), coarse), so);
  ASSERT_GT(sys->hierarchy->num_leaves(), 4 * sys->hierarchy->num_roots());  // refined
  if (!light) {
    ASSERT_GT(sys->hierarchy->num_leaves(), 20 * sys->hierarchy->num_roots());  // deep
  }
  const SolveResult r = converged(*sys);
  GatherOptions limit = final_options(light ? 16 : 1024),
                read = GatherOptions::final_gather(IndirectMode::kMesh);
  limit.reflector_samples = 0;
  const Image reference = gather_image(*sys, r.u, limit);
  const RegionMap regions = object_regions(*sys->world);
  auto compare = [&](const GatherOptions& o) {
    return compare_images(gather_image(*sys, r.u, o), reference, {}, &regions);
  };
  auto worst_region = [](const ImageComparison& c) {  // over the regions of 20 pixels or more
    double worst = 0.0;
    for (const RegionFigures& g : c.regions)
      if (g.pixels >= 20) worst = std::max(worst, std::abs(g.luminance_difference));
    return worst;
  };
  const ImageComparison near = compare(read);
  read.mesh_near_distance = 0.0;
  const ImageComparison everywhere = compare(read);
  std::printf(
      "against %d cosine samples: the mesh read everywhere %.4f (worst region %.4f), "
      "rays near surfaces %.4f (%.4f)\n",
      limit.gather_samples, everywhere.relative_rmse, worst_region(everywhere), near.relative_rmse,
      worst_region(near));
  if (light) return;
  EXPECT_LT(worst_region(near), 0.02);
  EXPECT_LT(near.relative_rmse, 0.7 * everywhere.relative_rmse);
}

TEST(FinalGather, IndirectLightFromTheMeshNeedsTheMeshsDirectLight) {
  auto sys = build_system(World::build(test::scene_from_json(test::closed_box_json(
      Vec3(1, 1, 1), 0.5, std::vector<std::string>(6, grey("diffuse", 0.5)), 1.0))));
  GatherOptions o = final_options();
  o.indirect = IndirectMode::kMesh;
  EXPECT_THROW(build_gather(*sys->world, sys->transport.layout(), o), InputError);
  const MeshDirect d = mesh_direct(sys->transport, sys->patches());
  EXPECT_EQ(d.objects, 6);  // every face emits
  EXPECT_NO_THROW(build_gather(*sys->world, sys->transport.layout(), o, &d));
  o.light_samples = 0;  // the direct light would then be lost
  EXPECT_THROW(build_gather(*sys->world, sys->transport.layout(), o, &d), InputError);
}

// ---- the operator ------------------------------------------------------------------------------

std::unique_ptr<RadiositySystem> small_view(const std::string& name, int size) {
  Scene scene = load_scene(test::scene_path(name));
  scene.camera.width = scene.camera.height = size;
  return build_system(World::build(std::move(scene)));
}

SeriesOperator precompute(const RadiositySystem& sys, const Gather* g, SeriesOutput output,
                          int order) {
  SeriesOptions o;
  o.order = order;
  o.output = output;
  o.progress = false;
  return precompute_series(sys.transport, *sys.world, o, g);
}

std::vector<float> product(const SeriesOperator& q, const std::vector<float>& e) {
  std::vector<float> out(3 * q.rows());
  q.apply(e.data(), out.data());
  return out;
}

float worst_difference(const std::vector<float>& a, const std::vector<float>& b) {
  EXPECT_EQ(a.size(), b.size());
  float worst = 0.0f;
  for (size_t k = 0; k < a.size(); ++k) worst = std::max(worst, std::abs(a[k] - b[k]));
  return worst;
}

TEST(FinalGather, DeferredRowsAreTheStoredRows) {
  auto sys = small_view("cornell-mirror-cube", 32);
  const GatherOptions o = final_options();
  Gather stored = build_gather(*sys->world, sys->transport.layout(), o);
  Gather deferred = defer_gather(*sys->world, sys->world->camera(), sys->transport.layout(), o);
  ASSERT_EQ(stored.g.rows, 32 * 32);
  ASSERT_EQ(stored.e.rows, 32 * 32);
  ASSERT_GT(stored.e.nnz(), 0);
  int blocks = 0;
  GatherWork work = for_each_gather_block(
      deferred, 500, [&](std::int64_t r0, const Csr<Rgbf>& g, const Csr<Rgbf>& e) {
        ++blocks;
        EXPECT_EQ(g.rows, e.rows);
        for (std::int64_t r = 0; r < g.rows; ++r) {
          ASSERT_EQ(g.start[r + 1] - g.start[r],
                    stored.g.start[r0 + r + 1] - stored.g.start[r0 + r]);
          for (auto k = g.start[r], s = stored.g.start[r0 + r]; k < g.start[r + 1]; ++k, ++s) {
            EXPECT_EQ(g.column[k], stored.g.column[s]);
            EXPECT_EQ(g.value[k], stored.g.value[s]);
          }
          ASSERT_EQ(e.start[r + 1] - e.start[r],
                    stored.e.start[r0 + r + 1] - stored.e.start[r0 + r]);
          for (auto k = e.start[r], s = stored.e.start[r0 + r]; k < e.start[r + 1]; ++k, ++s) {
            EXPECT_EQ(e.column[k], stored.e.column[s]);
            EXPECT_EQ(e.value[k], stored.e.value[s]);
          }
        }
      });
  EXPECT_EQ(blocks, 3);  // 1024 pixels in blocks of fifteen 32-pixel rows
  // Each block also casts the coarse rays of the rows beside it (4 rows more, 4 rays a pixel,
  // each along its chain of up to mirror_depth mirrors).
  EXPECT_GT(work.rays, stored.rays);
  EXPECT_LE(work.rays, stored.rays + 4 * 32 * 4 * (1 + o.mirror_depth));
  // The patch gather has no emission part.
  Gather patch = build_gather(*sys->world, sys->transport.layout(), GatherOptions{});
  EXPECT_EQ(patch.e.rows, 0);
}

void expect_same_rows(const Csr<Rgbf>& a, const Csr<Rgbf>& b) {
  ASSERT_EQ(a.rows, b.rows);
  ASSERT_EQ(a.start, b.start);
  EXPECT_EQ(a.column, b.column);
  for (std::size_t k = 0; k < a.value.size(); ++k) ASSERT_EQ(a.value[k], b.value[k]) << k;
}

// The finer rays cast only where the coarse ones or a shading ray meet more than one path class
// or a lamp, or on the image's border: the same gather as casting them everywhere where no
// feature thinner than the coarse rays' spacing lies between them, as none does at these sizes
// (the lamp, the blocks and their images in the mirror cut pixels at many fractions). Without
// the neighbours' coarse rays, or with the border's pixels left to the coarse rays, it fails.
// From 14 pixels a side fewer rays are cast (below, most pixels lie on an edge or the border).
TEST(FinalGather, FinerRaysWhereNeededGiveTheGatherOfFinerRaysEverywhere) {
  // Under the sanitizers the two smallest sizes (the larger took a minute more there).
  for (const char* scene : {"cornell-mirror-cube", "cornell-box"})
    for (const int size : test::refinement_steps(std::vector<int>{8, 14, 20, 29, 37}, 2)) {
      auto sys = small_view(scene, size);
      GatherOptions where = final_options(1, 1), everywhere = where;
      everywhere.emission_grid_everywhere = true;
      const Gather a = build_gather(*sys->world, sys->transport.layout(), where);
      const Gather b = build_gather(*sys->world, sys->transport.layout(), everywhere);
      expect_same_rows(a.g, b.g);
      expect_same_rows(a.e, b.e);
      if (size >= 14) {
        EXPECT_LT(a.rays, b.rays) << scene << " " << size;
      }
    }
}

TEST(FinalGather, GatherIsLinearInTheUnknownsAndTheEmission) {
  auto sys = small_view("cornell-mirror-cube", 32);
  Gather g = build_gather(*sys->world, sys->transport.layout(), final_options());
  Field u1 = Field::Random(sys->transport.size(), 3).cwiseAbs();
  Field u2 = Field::Random(sys->transport.size(), 3).cwiseAbs();
  std::vector<Rgb> e1 = scene_emission(sys->patches()), e2(e1.size()), e12(e1.size());
  for (size_t p = 0; p < e1.size(); ++p) {
    e2[p] = sys->patches()[p].emitter ? Rgb(0.5 + p % 3, 1.0, 2.0) : Rgb::Zero();
    e12[p] = e1[p] + 2.0 * e2[p];
  }
  Image a = apply_gather(g, u1, e1), b = apply_gather(g, u2, e2),
        ab = apply_gather(g, u1 + 2.0 * u2, e12);
  double worst = 0.0;
  for (size_t k = 0; k < a.rgb.size(); ++k)
    worst =
        std::max(worst, static_cast<double>(std::abs(ab.rgb[k] - (a.rgb[k] + 2.0f * b.rgb[k]))));
  EXPECT_LT(worst, 1e-4);
  EXPECT_THROW(apply_gather(g, u1), InputError);  // the final gather needs the emission
}

// The view product against `stored` applied to the solution-mode product of the same order: for
// the scene's lights, and for lights relit to other colours (which only the emission part E S
// can get right, the solution's B holding the relit emission too).
using Lights = std::map<std::string, Rgb>;
void expect_relight_is_render(const RadiositySystem& sys, const SeriesOperator& view,
                              const SeriesOperator& solution, const Gather& stored,
                              const std::vector<Lights>& relights = {
                                  Lights{}, Lights{{"light", Rgb(2, 8, 30)}}}) {
  for (const Lights& lights : relights) {
    std::vector<float> e = view.column_emission(lights);
    std::vector<float> relit = product(view, e);
    Image rendered = apply_gather(stored, series_field(solution, product(solution, e)),
                                  patch_emission(solution, e, sys.patches(), sys.scene()));
    float peak = 0.0f;
    for (float v : relit) peak = std::max(peak, v);
    EXPECT_GT(peak, 0.0f);
    EXPECT_LT(worst_difference(relit, rendered.rgb), 1e-5f * peak);
  }
}

// Q = E S + G P_K S, folded in blocks from a deferred gather, against the same gather built whole.
TEST(FinalGather, RelightIsRenderWithTheSameGather) {
  auto sys = small_view("cornell-mirror-cube", 32);
  const GatherOptions o = final_options();
  Gather deferred = defer_gather(*sys->world, sys->world->camera(), sys->transport.layout(), o);
  Gather stored = build_gather(*sys->world, sys->transport.layout(), o);
  SeriesOperator view = precompute(*sys, &deferred, SeriesOutput::kView, 9);
  SeriesOperator solution = precompute(*sys, nullptr, SeriesOutput::kSolution, 9);
  EXPECT_EQ(view.gather.kind, GatherKind::kFinal);
  EXPECT_GT(view.report.gather.seconds, 0.0);
  expect_relight_is_render(*sys, view, solution, stored);
  // The folded operator is one matrix: twice the light, twice the image.
  std::vector<float> e = view.column_emission(), e2 = e;
  for (float& v : e2) v *= 2.0f;
  std::vector<float> once = product(view, e), twice = product(view, e2);
  for (float& v : once) v *= 2.0f;
  float peak = 0.0f;
  for (float v : twice) peak = std::max(peak, v);
  EXPECT_LT(worst_difference(once, twice), 1e-6f * peak);
}

TEST(FinalGather, IterativeRenderAndRelightAgreeToTheSeriesTolerance) {
  // The view product (tolerance 1e-4) against the converged solution through the same gather.
  auto sys = small_view("cornell-box", 32);
  const GatherOptions o = final_options();
  Gather deferred = defer_gather(*sys->world, sys->world->camera(), sys->transport.layout(), o);
  SeriesOptions so;
  so.tolerance = 1e-4;
  so.progress = false;
  SeriesOperator view = precompute_series(sys->transport, *sys->world, so, &deferred);
  std::vector<float> relit = product(view, view.column_emission());
  Image rendered = apply_gather(deferred, converged(*sys).u, scene_emission(sys->patches()));
  double diff = 0.0, total = 0.0;
  for (size_t k = 0; k < relit.size(); ++k) {
    diff += std::abs(relit[k] - rendered.rgb[k]);
    total += rendered.rgb[k];
  }
  EXPECT_LT(diff / total, 1e-3);
}

// With the indirect light from the mesh the view precompute builds its own gather and the mesh's
// direct light (E then carries -D e, each emitting object's on its first patch): its product is
// the render of the same solution through the same gather, for the scene's light and another.
TEST(FinalGather, RelightIsRenderWithTheIndirectLightFromTheMesh) {
  auto sys = small_view("cornell-mirror-cube", 32);
  GatherOptions o = final_options();
  o.indirect = IndirectMode::kMesh;
  const auto direct = mesh_direct_for(o, sys->transport, *sys->world);  // with mirror images
  Gather stored = build_gather(*sys->world, sys->transport.layout(), o, direct.get());
  EXPECT_GT(stored.options.mirror_image_samples, 0);
  SeriesOptions so;
  so.order = 9;
  so.output = SeriesOutput::kView;
  so.progress = false;
  so.gather = o;
  SeriesOperator view = precompute_series(sys->transport, *sys->world, so);
  SeriesOperator solution = precompute(*sys, nullptr, SeriesOutput::kSolution, 9);
  EXPECT_EQ(view.gather.indirect, IndirectMode::kMesh);
  expect_relight_is_render(*sys, view, solution, stored);
}

// D(l, o) is each emitting object's own first bounce, and -D e lands on the object's column:
// with every face of a box a light of its own colour (three of them dark), sum_o D(l, o) E_o is
// T e on every B unknown of both meshes, and a view operator relit with one light off and
// another recoloured is the render of the same lights through the same gather.
TEST(FinalGather, MeshDirectIsEachLightsFirstBounce) {
  Scene scene = test::scene_from_json(test::closed_box_json(
      Vec3(1, 1.2, 0.9), 0.3,
      {grey("diffuse", 0.6), grey("mirror", 0.6), lambert_plus_mirror(0.3, 0.3),
       grey("diffuse", 0.5), grey("diffuse", 0.6), lambert_plus_mirror(0.2, 0.4)},
      1.0));
  scene.camera.width = scene.camera.height = 16;
  const Lights colours = {
      {"ceiling", Rgb(2, 1, 0.5)}, {"left", Rgb(0, 0, 0.3)}, {"back", Rgb(1, 1, 1)}};
  for (SceneObject& o : scene.objects) {
    const auto it = colours.find(o.name);
    o.emission = it != colours.end() ? it->second : Rgb::Zero();
  }
  for (MeshKind mesh : {MeshKind::kUniform, MeshKind::kHierarchical}) {
    SystemOptions so;
    so.mesh = mesh;
    auto sys = build_system(World::build(scene), so);
    const TransportOperator& t = sys->transport;
    const MeshDirect d = mesh_direct(t, sys->patches());
    ASSERT_EQ(d.objects, 6);
    // sum_o v(o)[c] E_o[c]: per-object values under the scene's lights.
    const auto lit = [&](const MeshDirect& m, const auto& v, int c) {
      double sum = 0.0;
      for (int o = 0; o < m.objects; ++o) sum += v(o)[c] * sys->patches()[m.column[o]].emission[c];
      return sum;
    };
    Field te;
    t.apply(t.emission(), te);
    Gap first;
    for (Eigen::Index l = 0; l < t.num_patches(); ++l)
      for (int c = 0; c < 3; ++c)
        first.add(lit(
                      d, [&](int o) { return d.at(l, o); }, c),
                  te(l, c));
    EXPECT_GT(first.peak, 0.0);
    EXPECT_LT(first.worst, 1e-5 * first.peak) << enum_name(mesh);
    // With the materials, the mirrors' links too, and their bounce after: sum_o of each link's
    // row times E_o is T e on that link, and sum_o mirrored(l, o) E_o is T applied to the
    // mirrors' links of T e alone.
    const MeshDirect dl = mesh_direct(t, sys->patches(), &sys->world->materials(), true);
    Field links_only = Field::Zero(te.rows(), 3), tm;
    long long mirror_links = 0;
    Gap links;
    for (std::size_t k = 0; k < dl.link_row.size(); ++k) {
      const std::int32_t row = dl.link_row[k];
      const auto u = static_cast<Eigen::Index>(t.num_patches() + static_cast<std::int64_t>(k));
      if (row < 0) continue;
      ++mirror_links;
      links_only.row(u) = te.row(u);
      for (int c = 0; c < 3; ++c)
        links.add(lit(
                      dl, [&](int o) { return dl.link_at(row, o); }, c),
                  te(u, c));
    }
    EXPECT_GT(mirror_links, 0) << enum_name(mesh);
    EXPECT_GT(links.peak, 0.0) << enum_name(mesh);
    EXPECT_LT(links.worst, 1e-5 * links.peak) << enum_name(mesh);
    t.apply(links_only, tm);
    Gap bounce;
    for (Eigen::Index l = 0; l < t.num_patches(); ++l)
      for (int c = 0; c < 3; ++c)
        bounce.add(lit(
                       dl, [&](int o) { return dl.mirrored_at(l, o); }, c),
                   tm(l, c));
    EXPECT_GT(bounce.peak, 0.0) << enum_name(mesh);
    EXPECT_LT(bounce.worst, 1e-5 * bounce.peak) << enum_name(mesh);
    // The gather's use of D: on the first bounce's solution B = E + T e, what each pixel reads
    // from the mesh, B - E - D e, is nothing, so the image is the one with D = 0 read on B = E.
    GatherOptions o = final_options();
    o.indirect = IndirectMode::kMesh;
    MeshDirect none = d;
    std::fill(none.value.begin(), none.value.end(), std::array<float, 3>{0.0f, 0.0f, 0.0f});
    const std::vector<Rgb> emission = scene_emission(sys->patches());
    const Image first_bounce =
        apply_gather(build_gather(*sys->world, t.layout(), o, &d), t.emission() + te, emission);
    const Image direct_only =
        apply_gather(build_gather(*sys->world, t.layout(), o, &none), t.emission(), emission);
    float image_peak = 0.0f;
    for (float v : direct_only.rgb) image_peak = std::max(image_peak, v);
    EXPECT_GT(image_peak, 0.0f);
    EXPECT_LT(worst_difference(first_bounce.rgb, direct_only.rgb), 1e-5f * image_peak)
        << enum_name(mesh);
    if (mesh == MeshKind::kHierarchical) continue;  // solution rows are the uniform mesh's
    // The view precompute makes its own MeshDirect, with the mirrors' links for the images.
    const auto with_links = mesh_direct_for(o, t, *sys->world);
    Gather stored = build_gather(*sys->world, t.layout(), o, with_links.get());
    SeriesOptions view_options;
    view_options.order = 9;
    view_options.progress = false;
    view_options.gather = o;
    SeriesOperator view = precompute_series(t, *sys->world, view_options);
    SeriesOperator solution = precompute(*sys, nullptr, SeriesOutput::kSolution, 9);
    expect_relight_is_render(
        *sys, view, solution, stored,
        {Lights{}, Lights{{"ceiling", Rgb(0, 0, 0)}, {"floor", Rgb(3, 0, 1)}}});
  }
}

// ---- the file ----------------------------------------------------------------------------------

// The operator file at `path` as an older polyrad wrote it: its header without the keys from
// `first` up to the next `next` (blanked to spaces, so no offset moves; checksum redone), read.
void read_without(const std::string& path, const char* first, const char* next,
                  SeriesOperator& out) {
  std::ifstream in(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t from = bytes.find(first), to = bytes.find(next, from);
  ASSERT_NE(from, std::string::npos);
  ASSERT_LT(from, to);
  std::fill(bytes.begin() + static_cast<std::ptrdiff_t>(from),
            bytes.begin() + static_cast<std::ptrdiff_t>(to), ' ');
  const std::uint64_t sum = checksum64(bytes.data(), bytes.size() - 8);
  std::memcpy(&bytes[bytes.size() - 8], &sum, 8);
  out = read_prt(test::write_file(std::filesystem::path(path).parent_path(), "older.prt", bytes));
}

TEST(FinalGather, FileRecordsTheGatherAndOlderFilesReadAsThePatchGather) {
  auto sys = build_system(World::load(test::scene_path("cornell-box")));
  SeriesOperator q = precompute(*sys, nullptr, SeriesOutput::kSolution, 3);
  q.gather = final_options(25, 9);
  q.gather.near_samples = 9;
  q.gather.mirror_depth = 2;
  q.gather.reflector_samples = 16;
  q.gather.mirror_image_samples = 8;
  q.gather.mirror_image_depth = 5;
  q.gather.mirror_chain_budget = 77;
  q.gather.through_mirrors = ThroughMirrors::kAlways;
  q.gather.indirect = IndirectMode::kMesh;
  q.gather.mesh_near_distance = 1.5;
  q.gather.mesh_near_samples = 36;
  q.gather.emission_grid_everywhere = true;
  q.gather.mesh_read = DiffuseMode::kFlat;
  auto dir = test::temp_dir();
  const std::string path = (dir / "final.prt").string();
  write_prt(q, path);
  SeriesOperator back = read_prt(path);
  EXPECT_EQ(back.gather.kind, GatherKind::kFinal);
  EXPECT_EQ(back.gather.gather_samples, 25);
  EXPECT_EQ(back.gather.light_samples, 9);
  EXPECT_EQ(back.gather.near_samples, 9);
  EXPECT_EQ(back.gather.mirror_depth, 2);
  EXPECT_EQ(back.gather.reflector_samples, 16);
  EXPECT_EQ(back.gather.mirror_image_samples, 8);
  EXPECT_EQ(back.gather.mirror_image_depth, 5);
  EXPECT_EQ(back.gather.mirror_chain_budget, 77);
  EXPECT_EQ(back.gather.through_mirrors, ThroughMirrors::kAlways);
  EXPECT_EQ(back.gather.indirect, IndirectMode::kMesh);
  EXPECT_EQ(back.gather.mesh_near_distance, 1.5);
  EXPECT_EQ(back.gather.mesh_near_samples, 36);
  EXPECT_TRUE(back.gather.emission_grid_everywhere);
  EXPECT_EQ(back.gather.mesh_read, DiffuseMode::kFlat);

  // The same file as written before the final gather existed: its header without the gather's
  // kind and final-gather counts.
  SeriesOperator old;
  ASSERT_NO_FATAL_FAILURE(read_without(path, "\"kind\"", "\"diffuse\"", old));
  EXPECT_EQ(old.gather.kind, GatherKind::kPatch);
  EXPECT_EQ(old.gather.light_samples, 9);
  EXPECT_EQ(old.gather.through_mirrors, ThroughMirrors::kNever);

  // A final gather written before the reflector points: none drawn.
  SeriesOperator before;
  ASSERT_NO_FATAL_FAILURE(read_without(path, "\"reflector_samples\"", "\"seed\"", before));
  EXPECT_EQ(before.gather.kind, GatherKind::kFinal);
  EXPECT_EQ(before.gather.gather_samples, 25);
  EXPECT_EQ(before.gather.reflector_samples, 0);
  EXPECT_EQ(before.gather.indirect, IndirectMode::kRays);

  // Written before the mirror images: none drawn.
  SeriesOperator no_images;
  ASSERT_NO_FATAL_FAILURE(
      read_without(path, "\"mirror_image_samples\"", "\"indirect\"", no_images));
  EXPECT_EQ(no_images.gather.mirror_image_samples, 0);
  EXPECT_EQ(no_images.gather.reflector_samples, 16);
  EXPECT_EQ(no_images.gather.indirect, IndirectMode::kMesh);

  // Written before samples read through mirrors: the mirrors' links read.
  SeriesOperator links;
  ASSERT_NO_FATAL_FAILURE(read_without(path, "\"through_mirrors\"", "\"indirect\"", links));
  EXPECT_EQ(links.gather.through_mirrors, ThroughMirrors::kNever);
  EXPECT_EQ(links.gather.mirror_image_samples, 8);

  // Written before the images went through chains of mirrors: one mirror.
  SeriesOperator one_mirror;
  ASSERT_NO_FATAL_FAILURE(
      read_without(path, "\"mirror_image_depth\"", "\"through_mirrors\"", one_mirror));
  EXPECT_EQ(one_mirror.gather.mirror_image_depth, 1);
  EXPECT_EQ(one_mirror.gather.mirror_image_samples, 8);

  // Written before the chains went past two planes taking turns: the default budget.
  SeriesOperator two_planes;
  ASSERT_NO_FATAL_FAILURE(
      read_without(path, "\"mirror_chain_budget\"", "\"through_mirrors\"", two_planes));
  EXPECT_EQ(two_planes.gather.mirror_chain_budget, GatherOptions{}.mirror_chain_budget);
  EXPECT_EQ(two_planes.gather.mirror_image_depth, 5);

  // Written before the mesh's near points were gathered by rays: the mesh read everywhere.
  SeriesOperator everywhere;
  ASSERT_NO_FATAL_FAILURE(read_without(path, "\"mesh_near_distance\"", "\"seed\"", everywhere));
  EXPECT_EQ(everywhere.gather.indirect, IndirectMode::kMesh);
  EXPECT_EQ(everywhere.gather.mesh_near_distance, 0.0);

  // Written before the finer rays were cast only where needed: cast everywhere.
  q.gather.emission_grid_everywhere = false;
  write_prt(q, path);
  EXPECT_FALSE(read_prt(path).gather.emission_grid_everywhere);
  SeriesOperator all_finer;
  ASSERT_NO_FATAL_FAILURE(
      read_without(path, "\"emission_grid_everywhere\"", "\"near_samples\"", all_finer));
  EXPECT_TRUE(all_finer.gather.emission_grid_everywhere);
  EXPECT_EQ(all_finer.gather.emission_grid, 8);

  // Written before the mesh's read at a point had its own mode: it read as the diffuse mode.
  for (const DiffuseMode diffuse : {DiffuseMode::kFlat, DiffuseMode::kSmooth}) {
    q.gather.diffuse = diffuse;
    q.gather.mesh_read = diffuse == DiffuseMode::kFlat ? DiffuseMode::kSmooth : DiffuseMode::kFlat;
    write_prt(q, path);
    EXPECT_EQ(read_prt(path).gather.mesh_read, q.gather.mesh_read);
    SeriesOperator before_reads;
    ASSERT_NO_FATAL_FAILURE(read_without(path, "\"mesh_read\"", "\"seed\"", before_reads));
    EXPECT_EQ(before_reads.gather.mesh_read, diffuse);
    EXPECT_EQ(before_reads.gather.mesh_near_samples, 36);
  }
  q.gather.diffuse = DiffuseMode::kFlat;

  // Written before the indirect light could come from the mesh: from rays.
  SeriesOperator rays;
  ASSERT_NO_FATAL_FAILURE(read_without(path, "\"indirect\"", "\"seed\"", rays));
  EXPECT_EQ(rays.gather.reflector_samples, 16);
  EXPECT_EQ(rays.gather.indirect, IndirectMode::kRays);
}

}  // namespace
}  // namespace polyrad
