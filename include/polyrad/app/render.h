// Rendering a scene, by any method, as one library call: the workflow behind `polyrad render`.
//
//   iterative  the radiosity system, solved by an iterative solver, through the camera gather;
//   series     the same system through the precomputed power series (view rows), relit once
//              with the scene's emission;
//   pathtrace  the path-traced reference over the same patches, materials and camera.
//
//   RenderOptions o;
//   o.method = RenderMethod::kSeries;
//   o.overrides.patch_size = 25;
//   RenderResult r = render("scenes/cornell-box.json", o);
//   write_image(r.image, "out.exr");
//
// Throws InputError for a bad scene or options, NumericalError when the solve diverges, does
// not converge, or the image is not finite. Cost: the stages of the method chosen.
#pragma once

#include <memory>
#include <string>

#include "polyrad/app/report.h"
#include "polyrad/render/camera_gather.h"
#include "polyrad/render/image.h"
#include "polyrad/render/path_tracer.h"
#include "polyrad/solve/series_precompute.h"
#include "polyrad/solve/solver.h"
#include "polyrad/transport/system.h"
#include "polyrad/util/enum_names.h"

namespace polyrad {

enum class RenderMethod { kIterative, kSeries, kPathTrace };
template <>
struct EnumNames<RenderMethod> {
  static constexpr const char* kind = "render method";
  static constexpr std::array<std::pair<RenderMethod, const char*>, 3> table{
      {{RenderMethod::kIterative, "iterative"},
       {RenderMethod::kSeries, "series"},
       {RenderMethod::kPathTrace, "pathtrace"}}};
};

struct RenderOptions {
  RenderMethod method = RenderMethod::kIterative;
  SceneOptions scene;
  SceneOverrides overrides;
  SystemOptions system;  // a mesh left unset, a link tolerance left 0: system_for_gather
  SolveOptions solve;                                    // iterative
  SeriesOptions series;                                  // series (its output is always view rows)
  PathTraceOptions pathtrace;                            // pathtrace
  GatherOptions gather = GatherOptions::final_gather();  // iterative and series
  // The image goes to an .exr or a .png (image_needs_codec): the codec module's memory is
  // counted in the estimate, since it loads while the run's system is still held.
  bool image_codec = true;
};

struct RenderResult {
  Image image;
  Report report;
  std::shared_ptr<const World> world;
  // iterative: the system and its solution (for a table of patch radiosities); else null/empty.
  std::unique_ptr<RadiositySystem> system;
  Field u;
};

RenderResult render(const std::string& scene_path, const RenderOptions& options);

// The image of a solution through a gather (with the scene's emission, which a final gather
// reads), checked finite; work, when given, receives what reading the gather cost.
Image gather_image(const Gather& gather, const Field& u, const World& world,
                   GatherWork* work = nullptr);

}  // namespace polyrad
