// A path-traced reference kept on disk beside the results measured against it, so that reruns
// with other knobs reuse it: DIR/reference.exr and DIR/reference.json (the key it was made with
// and its cost). A key that differs (scene text, camera, samples, seed, depth) makes the cached
// image stale; it is rendered again.
//
//   CachedReference ref = cached_reference("out/sweep", *world, {.spp = 1024, .seed = 7});
//   compare_images(radiosity, ref.image);
//
// Cost: the path tracer's (spp x pixels x path length), or one EXR read when cached.
#pragma once

#include <string>

#include "polyrad/render/image.h"
#include "polyrad/render/path_tracer.h"
#include "polyrad/world/world.h"

namespace polyrad {

struct CachedReference {
  Image image;
  double seconds = 0.0;  // what rendering it took (when it was rendered)
  PathStats stats;       // its paths, rays and paths cut at max_depth (kept with the key)
  bool reused = false;   // read from the cache
};

// What a cached image was made from, as one string; any difference makes it stale.
std::string reference_key(const Scene& scene, const PathTraceOptions& options);

// The image is written as half-float EXR and read back, so that a first run and a rerun
// measure against the same values.
CachedReference cached_reference(const std::string& dir, const World& world,
                                 const PathTraceOptions& options);

}  // namespace polyrad
