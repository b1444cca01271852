// Helpers shared by the test programs: temporary folders, files, scenes built from text, patches,
// runs of the command line, and closed forms of the form factor.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "polyrad/geometry/mesher.h"
#include "polyrad/scene/scene.h"
#include "polyrad/transport/transport.h"
#include "polyrad/util/json.h"

namespace polyrad::test {

// Whether this build runs under AddressSanitizer (GCC says so by a macro, Clang by a feature).
#if defined(__SANITIZE_ADDRESS__)
#define POLYRAD_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define POLYRAD_TEST_ASAN 1
#endif
#endif
#ifdef POLYRAD_TEST_ASAN
inline constexpr bool kUnderAddressSanitizer = true;
#else
inline constexpr bool kUnderAddressSanitizer = false;
#endif

// The steps of a refinement sequence that a test walks, coarse to fine: all of them, or under
// the sanitizers only the first `keep`. The sanitizers look for memory errors and undefined
// behaviour, which the coarse steps meet in the same code; the fine steps check convergence,
// which the Release suite does, and under the sanitizers each took minutes. A test's checks on
// its finest step name that step's value, so they run in Release only.
template <typename T>
std::vector<T> refinement_steps(std::vector<T> steps, std::size_t keep = 1) {
  if (kUnderAddressSanitizer && steps.size() > keep) steps.resize(keep);
  return steps;
}

// A fresh empty directory under the system's temporary folder, removed at exit.
std::filesystem::path temp_dir();

// Writes text to dir/name and returns the path.
std::string write_file(const std::filesystem::path& dir, const std::string& name,
                       const std::string& text);

// The whole of a file ("" when it cannot be read), and a JSON file parsed (InputError if not).
std::string read_text(const std::filesystem::path& path);
JsonValue read_json(const std::filesystem::path& path);

// A command's exit code and what it wrote on stdout and stderr.
struct CommandRun {
  int code = -1;
  std::string out, err;
};
CommandRun run_shell(const std::string& command);
// `polyrad --quiet ARGS`, the binary of this build.
CommandRun run_cli(const std::string& args);

// Loads a scene from JSON text (written to a temporary file so mesh paths resolve there).
Scene scene_from_json(const std::string& json, const std::filesystem::path& dir = {});

std::string scene_path(const std::string& name);  // scenes/<name>.json of the source tree

// A patch from four corners (counter-clockwise seen from the front).
Patch make_quad(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);
PatchSet make_patch_set(std::vector<Patch> patches);

// JSON of a closed axis-aligned box [0,sx]x[0,sy]x[0,sz] with inward faces, every face of
// material "m" (JSON text of the material) and emission e, patch size p. The camera sits inside.
std::string closed_box_json(const Vec3& size, double patch_size, const std::string& material,
                            double emission);
// The same box with one material per face, in the order floor, ceiling, left (x = 0),
// right, back (z = sz), front (z = 0).
std::string closed_box_json(const Vec3& size, double patch_size,
                            const std::vector<std::string>& face_materials, double emission);

// Gauss-Seidel sweeps of t's emission from the emission, on `threads` threads (the team is set
// back to every processor after).
Field gauss_seidel_on(const TransportOperator& t, int threads, int sweeps);

// A lamp (emission 1, black, 0.4 x 0.4 at x in [-1.2, -0.8], height 1, facing down) and a
// receiver (reflectance 0.5, x in [rx0, rx1]) side by side above a mirror floor (reflectance
// 0.8, [mx0, mx1] x [mz0, mz1] at height 0): light reaches the receiver only by the mirror, as if
// from the lamp's mirror image 2 below it.
std::string mirror_floor_json(double rx0, double rx1, double mx0, double mx1, double mz0,
                              double mz1);

// scenes/stability/facing-mirrors-black.json: two mirrors of 0.99 face each other across a
// corridor 0.2 wide, 1 high and 1 long whose ceiling and ends are black; a lamp 0.1 square hangs
// under the ceiling in the middle, and the floor (0.9) is the only other surface that reflects.
// The floor sees the lamp and, unfolded through the mirrors, its images: the k-th at x + 0.2 k
// after |k| reflections, each whole (the mirrors fill the corridor's sides, and a segment
// between two points of the unfolded corridor stays in it). So its radiance is
// L(x) = 0.9 sum_k 0.99^|k| F(x -> lamp_k) exactly (section 8's mirror image, repeated); the
// floor's own light never comes back (its images lie in its plane, the rest is black). Here the
// camera looks straight down at the floor's middle from half the corridor's height: 8 x 8
// pixels that see only the floor (x and z within 0.07 of the middle).
Scene facing_mirrors_black();
// L(x) at a floor point, the sum over the images to |k| = 150 (a term there is 3e-7 of the
// first, the rest of the series 2e-6 of the sum).
double facing_mirrors_floor_radiance(const Vec3& x);
// Its mean over the floor: at the midpoints of a 10 x 50 grid (a 20 x 100 grid moves it by
// 2.5e-5).
double facing_mirrors_floor_mean();

// scenes/stability/mirrored-room: a room 0.4 x 0.4 x 1 whose four walls are mirrors of 0.9, its
// floor white (0.9), its ceiling black but for a lamp 0.1 square in the middle, seen from above
// (8 x 8 pixels, all floor). Unfolded through the walls the lamp's images fill a lattice, the
// (i, j)-th moved by (0.4 i, 0.4 j) after |i| + |j| reflections (the lamp is centred, so an image
// mirrored in place is the same square): the floor's radiance is
// L(x) = 0.9 sum_ij 0.9^(|i| + |j|) F(x -> lamp_ij) exactly (scripts/mirrored_room_exact.py).
Scene mirrored_room();
double mirrored_room_floor_radiance(const Vec3& x);

// The form factor of two directly opposed parallel a x b rectangles at distance c
// (papers/glossy-radiosity.md, section 10) and of perpendicular rectangles sharing an edge of
// length l, from the w-side to the h-side.
double parallel_rectangles_ff(double a, double b, double c);
double perpendicular_rectangles_ff(double l, double w, double h);

}  // namespace polyrad::test

namespace polyrad::test {

// Form factor from rectangle 1 = [x1,x2] x [y1,y2] in the plane z = 0 to the parallel
// rectangle 2 = [xi1,xi2] x [eta1,eta2] in the plane z = c facing it, by the closed-form
// superposition of corner contributions (valid for any lateral offset).
double parallel_offset_rectangles_ff(double x1, double x2, double y1, double y2, double xi1,
                                     double xi2, double eta1, double eta2, double c);

}  // namespace polyrad::test
