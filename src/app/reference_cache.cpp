// Path-traced references cached on disk (app/reference_cache.h).
#include "polyrad/app/reference_cache.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "polyrad/io/image_io.h"
#include "polyrad/util/files.h"
#include "polyrad/util/json.h"

namespace polyrad {

std::string reference_key(const Scene& scene, const PathTraceOptions& o) {
  std::ostringstream k;
  k << "scene_hash=" << scene.hash << ";camera=" << scene.camera.width << "x" << scene.camera.height
    << ";spp=" << o.spp << ";seed=" << o.seed << ";max_depth=" << o.max_depth
    << ";roulette_depth=" << o.roulette_depth;
  return k.str();
}

namespace {

// The counts kept beside the key (cached_reference takes a file without them as stale); a
// damaged value reads as 0, or at most 2^53.
PathStats stored_stats(const JsonValue& stored) {
  auto count = [&](const char* name) {
    const JsonValue* v = stored.find(name);
    if (!v || !v->is(JsonValue::Kind::kNumber) || !(v->number >= 0.0)) return 0LL;
    return static_cast<long long>(std::min(v->number, 0x1p53));
  };
  PathStats s;
  s.paths = count("paths");
  s.rays = count("rays");
  s.truncated = count("paths_truncated");
  return s;
}

}  // namespace

CachedReference cached_reference(const std::string& dir, const World& world,
                                 const PathTraceOptions& o) {
  const std::string image_path = dir + "/reference.exr", key_path = dir + "/reference.json";
  const std::string key = reference_key(world.scene(), o);
  CachedReference ref;
  if (std::filesystem::exists(image_path) && std::filesystem::exists(key_path)) {
    const JsonValue stored = parse_json(read_text_file(key_path, "the reference's key"), key_path);
    const JsonValue* k = stored.find("key");
    // One written before the counts were kept beside the key is stale: its cut paths unknown.
    if (k && k->is(JsonValue::Kind::kString) && k->string == key && stored.find("paths")) {
      ref.image = read_image(image_path);
      const JsonValue* s = stored.find("seconds");
      ref.seconds = s && s->is(JsonValue::Kind::kNumber) ? s->number : std::nan("");
      ref.stats = stored_stats(stored);
      ref.reused = true;
      return ref;
    }
    std::fprintf(stderr,
                 "polyrad: %s is stale (other scene, camera, samples or depth, or no count of "
                 "its cut paths); rendering it again\n",
                 image_path.c_str());
  }
  const PathTraceResult r = PathTracer(world).render(world.camera(), o);
  if (!r.image.all_finite())
    throw NumericalError("the path-traced reference has non-finite pixels");
  write_image(r.image, image_path);
  JsonWriter w;
  w.begin_object()
      .value("key", key)
      .value("seconds", r.seconds)
      .value("rays", r.stats.rays)
      .value("paths", r.stats.paths)
      .value("paths_truncated", r.stats.truncated)
      .end_object();
  write_file_atomic(key_path, w.str());
  ref.image = read_image(image_path);
  ref.seconds = r.seconds;
  ref.stats = r.stats;
  return ref;
}

}  // namespace polyrad
