// Relighting a stored operator: the workflow behind `polyrad relight` and the page of
// `polyrad serve`. A Relighter holds the operator (read by mmap and checked against its scene)
// and, for solution rows, the world and the gather that turn a relit solution into an image;
// each new set of lights then costs one product.
//
//   Relighter r("out/scene.prt");
//   std::vector<float> e = r.emission({{"light", Rgb(34, 24, 8)}});
//   Image img = r.image(e);
//
//   RelightResult res = relight("out/scene.prt", {.emission = {{"light", Rgb(0, 0, 20)}}});
//
// Cost: construction reads the file (and, for solution rows, meshes the scene and builds the
// gather); image() is one product over Q (plus, for solution rows, one gather product).
// Thread-safe: image() and emission() may run on any number of threads at once.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "polyrad/app/report.h"
#include "polyrad/render/camera_gather.h"
#include "polyrad/solve/series_operator.h"
#include "polyrad/world/world.h"

namespace polyrad {

class Relighter {
 public:
  // scene_path: the scene when it moved since the precompute ("" reads the recorded one).
  explicit Relighter(const std::string& prt_path, const std::string& scene_path = {});

  const SeriesOperator& op() const { return q_; }
  int width() const;  // of the images image() returns
  int height() const;
  // The lights by name in column order, each with the scene's emission.
  std::vector<std::pair<std::string, Rgb>> lights() const;
  // The emission of each column: the scene's, with the named lights set. InputError for a name
  // that is not a light, or a value that is negative or not finite.
  std::vector<float> emission(const std::map<std::string, Rgb>& lights) const;
  // The image for those emissions: one product, and for solution rows the gather (the scene
  // camera's unless another is given). product_seconds, when given, receives the product's time.
  Image image(const std::vector<float>& e, const Gather* gather = nullptr,
              double* product_seconds = nullptr) const;
  // Solution rows only: the gather of another camera (InputError for view rows).
  Gather camera_gather(const Camera& camera) const;
  // Solution rows: the world the operator reads (null for view rows).
  const std::shared_ptr<const World>& world() const { return world_; }
  double load_seconds() const { return load_seconds_; }
  double gather_seconds() const { return gather_ ? gather_->seconds : 0.0; }

 private:
  SeriesOperator q_;
  std::shared_ptr<const World> world_;
  std::unique_ptr<Gather> gather_;  // solution rows: the scene camera's
  double load_seconds_ = 0.0;
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
