#include "polyrad/pipeline.h"

#include <sys/resource.h>

#include <chrono>

namespace polyrad {

namespace {

class Stopwatch {
 public:
  double lap() {
    auto now = std::chrono::steady_clock::now();
    double s = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    return s;
  }

 private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

}  // namespace

double RadiositySystem::seconds(const std::string& stage) const {
  for (const auto& t : times)
    if (t.name == stage) return t.seconds;
  return 0.0;
}

std::unique_ptr<RadiositySystem> build_system(Scene scene, const PipelineOptions& options) {
  auto sys = std::make_unique<RadiositySystem>();
  sys->scene = std::move(scene);
  if (options.patch_size > 0.0)
    for (auto& o : sys->scene.objects) o.patch_size = options.patch_size;
  Stopwatch watch;
  sys->patches = mesh_scene(sys->scene);
  sys->times.push_back({"mesh", watch.lap()});
  sys->caster = std::make_unique<RayCaster>(sys->patches);
  sys->times.push_back({"ray_caster", watch.lap()});
  sys->form_factors = compute_form_factors(sys->patches, *sys->caster, options.form_factors);
  sys->times.push_back({"form_factors", watch.lap()});
  const SpecularTransfer* specular = nullptr;
  if (options.specular_transport) {
    sys->specular = compute_specular_transfer(sys->patches, sys->scene.materials, sys->form_factors,
                                              *sys->caster, options.specular);
    specular = &sys->specular;
    sys->times.push_back({"specular_transfer", watch.lap()});
  }
  if (options.specular_transport && options.specular_on_the_fly) {
    OnTheFlySpecular source{&sys->patches, &sys->scene.materials, &sys->form_factors,
                            sys->caster.get(), options.specular};
    sys->transport = build_transport(sys->patches, sys->scene.materials, sys->form_factors,
                                     specular, &source);
    SpecularStats stats = sys->specular.stats;
    sys->specular = SpecularTransfer{};  // its entries are recomputed when needed
    sys->specular.stats = stats;
  } else {
    sys->transport = build_transport(sys->patches, sys->scene.materials, sys->form_factors, specular);
  }
  sys->times.push_back({"operator", watch.lap()});
  return sys;
}

std::size_t peak_memory_bytes() {
  struct rusage usage {};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<std::size_t>(usage.ru_maxrss) * 1024;  // Linux reports kilobytes
}

}  // namespace polyrad
