#include "polyrad/transport/system.h"

#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>

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

double physical_memory_bytes() {
  long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && page > 0 ? static_cast<double>(pages) * static_cast<double>(page) : 0.0;
}

void override_patch_size(Scene& scene, double patch_size) {
  if (patch_size > 0.0)
    for (auto& o : scene.objects) o.patch_size = patch_size;
}

MemoryEstimate estimate_memory(const Scene& scene, const PipelineOptions& options) {
  Scene s = scene;
  override_patch_size(s, options.patch_size);
  MemoryEstimate m;
  m.patches = count_patches(s);
  // Per facing pair: 8 bytes in each direction of the CSR, 16 in the per-row lists built first.
  m.form_factors = 0.5 * m.patches * m.patches * (8.0 * 2 + 16.0);
  if (options.specular_transport) {
    double reflecting = 0.0;
    for (const auto& o : s.objects)
      if (s.materials[o.material].has_lobe()) {
        Scene one;
        one.objects = {o};
        one.materials = s.materials;
        reflecting += count_patches(one);
      }
    // Each (j -> i) pair: up to `samples` targets, 12 bytes stored, twice while balancing.
    m.specular = reflecting * 0.5 * m.patches * std::min(options.specular.samples, 64) * 12.0 * 2.0;
  }
  // Unknowns (patches + links) times 3 doubles, a few fields.
  m.fields = (m.patches + m.specular / 24.0) * 3 * 8 * 6;
  return m;
}

std::unique_ptr<RadiositySystem> build_system(Scene scene, const PipelineOptions& options) {
  const double budget = options.max_memory_bytes > 0.0 ? options.max_memory_bytes
                                                       : 0.8 * physical_memory_bytes();
  MemoryEstimate need = estimate_memory(scene, options);
  if (budget > 0.0 && need.total() > budget) {
    char text[512];
    std::snprintf(text, sizeof text,
                  "the scene needs an estimated %.3g GiB (%.3g patches: form factors %.3g GiB, "
                  "specular transfer %.3g GiB), more than the budget of %.3g GiB; use a larger "
                  "patch_size or raise --max-memory",
                  need.total() / (1 << 30), need.patches, need.form_factors / (1 << 30),
                  need.specular / (1 << 30), budget / (1 << 30));
    throw InputError(SourceLocation{scene.file}, text);
  }
  auto sys = std::make_unique<RadiositySystem>();
  sys->scene = std::move(scene);
  override_patch_size(sys->scene, options.patch_size);
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
    // Before the on-the-fly mode releases the entries: the check reads them (no rays).
    sys->lobes = check_lobe_resolution(sys->scene, sys->patches, sys->form_factors, sys->specular);
    sys->times.push_back({"lobe_check", watch.lap()});
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
