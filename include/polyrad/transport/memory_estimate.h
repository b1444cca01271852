// What a run will hold at its peak, estimated before the work, by part: so that work that does
// not fit is refused at once (InputError, exit code 2, with the estimate) and work that fits is
// not. The figures per part are calibrated against the peaks measured on the Cornell scenes
// (README, "Memory"); the estimate stays within a factor 1.5 of them.
//
//   base     the process: libraries, Embree's device, the scene                   15 MiB
//   world    the patches and their ray caster                       350 bytes a patch
//   system   the form factors and T's diffuse rows                48 bytes a visible pair
//            the specular transfer and T's link rows            50 bytes a transfer entry
//            (entries: each reflector patch's visible partners times the targets a pair
//            reaches, about 0.4 x samples for a mirror and 1.1 x samples for a lobe, at most
//            twice the partners)
//            a hierarchy: 260 bytes a visible root pair at link tolerance 0.05 and two
//            refinement passes, scaled by (0.05 / tau)^0.6 above 0.05, (0.05 / tau)^0.8 down
//            to 0.02 and then by (0.02 / tau)^1.5, by 0.4 with no pass after the first and 0.8
//            with one, and the product kept within 0.2 and 64 times, for the root pairs of the
//            scene's own patch sizes; each root pair beyond (or short of) those adds (or takes
//            away) one root link, 90 bytes or that product's 260 if less; all of it times
//            min(1, (2 / r)^1.33) for a smallest element r times the scene's own (refinement
//            stops there), but never under a root link a root pair; with lobes the transfer
//            on its roots and the root links' rows 35 bytes an entry
//   camera   set by each workflow: the gather (render/camera_gather.h, gather_memory), the
//            precompute's view rows (solve/series_precompute.h, rows_memory), images and,
//            where the workflow writes .exr or .png, the codec module (io/image_codec.h,
//            110 MiB and 12 bytes a pixel, counted in full: the system is still held when the
//            image is written)
// Visible pairs: before meshing, the pairs of faces that face each other, weighted by their
// patch counts, times 0.75 (the share of facing pairs the Cornell box sees unblocked; the check
// before meshing refuses only past a tenth); from a built world, 4096 random patch pairs tested
// by a plane test and a ray between centroids, and 4096 more from the reflectors' patches for
// their partners (a glossy floor sees more of a room than the mean patch does).
//
//   SystemOptions o;
//   o.camera_bytes = gather_memory(gather_options, pixels, true);
//   require_memory(estimate_memory(*world, o), memory_budget(o.max_memory_bytes),
//                  world->scene().file);
//
// Cost: O(faces^2) before meshing (sampled beyond 4000 faces); 8192 rays from a world.
#pragma once

#include <string>

namespace polyrad {

// transport/system.h holds a run's estimate, so this header only names what its functions read.
struct Scene;
struct SystemOptions;
class World;

struct MemoryEstimate {
  double patches = 0.0;        // count: the uniform mesh's (a hierarchy's roots)
  double visible_pairs = 0.0;  // count: patch pairs that see each other
  double base = 0.0, world = 0.0, system = 0.0, camera = 0.0;  // bytes
  double total() const { return base + world + system + camera; }
};

// Before meshing: scene with the overrides applied (apply_overrides).
MemoryEstimate estimate_memory(const Scene& scene, const SystemOptions& options);
// From a built world: visible pairs sampled with rays.
MemoryEstimate estimate_memory(const World& world, const SystemOptions& options);

// max_memory_bytes when positive, else 80 percent of the machine's physical memory.
double memory_budget(double max_memory_bytes);
// Throws InputError naming the file, the estimate by part and the budget when the estimate
// exceeds it.
void require_memory(const MemoryEstimate& need, double budget, const std::string& file);
// The check before meshing, on estimate_memory(Scene): refuses only what would not fit even if
// a tenth of the facing pairs saw each other (not three quarters), so that a scene whose pairs
// are mostly blocked is judged by the world's estimate, after meshing and before the form
// factors; a tiny patch size or a huge image is still refused at once.
void require_memory_before_meshing(const MemoryEstimate& need, double budget,
                                   const std::string& file);

}  // namespace polyrad
