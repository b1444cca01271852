// Relighting a stored operator: the workflow behind `polyrad relight` and the page of
// `polyrad serve`. A Relighter holds the operator (read by mmap and checked against its scene,
// io/prt_file.h) and, for solution rows, the world and the gathers that turn a relit solution
// into an image: the scene camera's, and the last few orbits of it (`Orbit`), so that a relight
// with an unchanged camera costs the product and one gather product.
//
//   Relighter r("out/scene.prt");                 // refuses a stale or damaged file (InputError)
//   Relit a = r.relight({{"light", Rgb(34, 24, 8)}});
//   RelightResult res = relight("out/scene.prt", {.emission = {{"light", Rgb(0, 0, 20)}}});
//
// Cost: construction maps the file and reads its checksum once (and, for solution rows, meshes
// the scene and builds the scene camera's gather); a relight is one product (nnz(Q) x 16 bytes
// read), plus for solution rows one gather product, and a gather build (pixels x rays) each time
// the camera moves to an orbit not in the cache. Thread-safe: relight() may run on any number of
// threads at once.
#pragma once

#include <cstddef>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "polyrad/app/report.h"
#include "polyrad/render/camera_gather.h"
#include "polyrad/solve/series_operator.h"
#include "polyrad/world/world.h"

namespace polyrad {

struct Light {
  std::string name;  // the emitting object's name in the scene
  Rgb emission;      // its scene emission
};

// The camera turned about its look-at point: yaw about the camera's up axis, then pitch towards
// it, both in degrees. {0, 0} is the scene camera. Only solution operators can orbit.
struct Orbit {
  double yaw_degrees = 0.0;
  double pitch_degrees = 0.0;
  bool operator==(const Orbit&) const = default;
};

// The camera `orbit` makes of `camera`; pitch is held 5 degrees short of the up axis either way.
Camera orbit_camera(const Camera& camera, const Orbit& orbit);

struct Relit {
  Image image;                   // linear radiance, as `polyrad relight` writes it to .pfm
  double product_seconds = 0.0;  // Q e
  double gather_seconds = 0.0;   // solution operators: the gather product, plus a build if the
                                 // orbit was not cached
  bool gather_built = false;     // this call built a gather
  std::optional<GatherSummary> gather;  // solution operators: the gather that made the image
};

class Relighter {
 public:
  // scene_path empty: the scene file named in the operator. Throws InputError for a missing,
  // damaged or stale operator, or a scene that no longer meshes as it did.
  explicit Relighter(const std::string& prt_path, const std::string& scene_path = "");
  ~Relighter();
  Relighter(const Relighter&) = delete;
  Relighter& operator=(const Relighter&) = delete;

  const std::vector<Light>& lights() const { return lights_; }
  int width() const;
  int height() const;
  SeriesOutput output() const { return q_.output; }
  bool can_orbit() const { return q_.output == SeriesOutput::kSolution; }
  const SeriesOperator& op() const { return q_; }
  // Reading the operator; for solution rows, the world and the scene camera's gather as well.
  double load_seconds() const { return load_seconds_; }
  // Why this operator's images lack the lamps' mirror images render would draw (a solution
  // operator written before it kept the mesh's direct light), or "".
  const std::string& missing_images() const { return missing_images_; }

  // The image for these emissions (lights not named keep their scene emission). Throws
  // InputError for an unknown light, a negative or non-finite emission, or an orbit given to a
  // view operator; NumericalError if the image is not finite.
  Relit relight(const std::map<std::string, Rgb>& emission, const Orbit& orbit = {}) const;

 private:
  struct Views;  // solution operators: the world and the gathers of its orbits
  SeriesOperator q_;
  std::vector<Light> lights_;
  std::unique_ptr<Views> views_;
  double load_seconds_ = 0.0;
  std::string missing_images_;
};

struct RelightOptions {
  std::string scene;                    // when it moved since the precompute
  std::map<std::string, Rgb> emission;  // lights to set; the others keep the scene's
  int repeats = 5;                      // the product is timed over this many (median)
};

struct RelightResult {
  Image image;
  Report report;
};

RelightResult relight(const std::string& prt_path, const RelightOptions& options);

}  // namespace polyrad
