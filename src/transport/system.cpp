// The glossy radiosity system of a world (transport/system.h).
#include "polyrad/transport/system.h"

#include <algorithm>
#include <cstdio>

#include "polyrad/transport/memory_estimate.h"
#include "polyrad/util/machine.h"

namespace polyrad {

SystemSummary RadiositySystem::summary() const {
  SystemSummary s;
  s.patches = static_cast<long long>(patches().size());
  s.links = transport.num_links();
  s.unknowns = static_cast<long long>(transport.size());
  s.form_factors = form_factors.stats;
  s.form_factor_nnz = form_factors.f.nnz();
  s.form_factor_bytes = form_factors.bytes();
  s.specular = specular.stats;
  s.specular_entries = static_cast<long long>(specular.entries());
  s.specular_bytes = specular.bytes();
  s.on_the_fly = transport.on_the_fly();
  s.nnz_diffuse = transport.nnz_diffuse();
  s.nnz_specular = transport.nnz_specular();
  s.operator_bytes = transport.bytes();
  s.max_albedo = transport.max_albedo();
  s.lobes = lobes;
  s.estimated_memory = estimated_memory;
  if (hierarchy) {
    s.mesh = MeshKind::kHierarchical;
    HierarchySummary h;
    h.roots = hierarchy->num_roots();
    h.elements = static_cast<long long>(hierarchy->elements().size());
    h.leaves = hierarchy->num_leaves();
    h.links = static_cast<long long>(hierarchy->links().size());
    h.link_entries = hierarchy->op()->link_entries();
    h.operator_bytes = hierarchy->op()->bytes();
    h.stats = hierarchy->stats();
    s.hierarchy = h;
    // The transfer on the roots is released once the operator holds its rows (eq. H3): its
    // entries and the rows' are the hierarchy's counts.
    s.specular_entries = h.stats.transfer_entries;
    s.nnz_specular = h.stats.specular_row_entries;
  }
  return s;
}

namespace {

// The hierarchical mesh's stages (transport/hierarchy.h): element trees on the world's patches,
// links refined pass by pass; with lobes, the specular links between the roots (eq. H3): root
// form factors from the links, the transfer on the roots as the uniform mesh computes it, the
// lobe check; then T on the leaves and the links.
void build_hierarchical(RadiositySystem& sys, const SystemOptions& options) {
  const World& w = *sys.world;
  // (With the hierarchy's specular links off, every material is reduced to its diffuse part.)
  bool lobes = false;
  for (const auto& o : w.scene().objects) lobes = lobes || w.materials()[o.material].has_lobe();
  lobes = lobes && options.hierarchy.specular_links;
  if (lobes && options.specular_on_the_fly)
    throw InputError(SourceLocation{w.scene().file},
                     "--specular-on-the-fly recomputes the uniform mesh's link rows; the "
                     "hierarchical mesh stores its root links' rows (use --mesh uniform)");
  HierarchyOptions ho = options.hierarchy;
  // The links may take what the budget leaves once the estimate's other parts are counted.
  // (No budget, where the machine's memory is not known: no limit, as require_memory.)
  const MemoryEstimate& need = sys.estimated_memory;
  const double budget = memory_budget(options.max_memory_bytes);
  ho.max_link_bytes =
      budget > 0.0 ? std::max(1.0, budget - need.base - need.world - need.camera) : 0.0;
  ho.form_factors = options.form_factors;
  ho.specular = options.specular;
  auto h = std::make_shared<ElementHierarchy>(
      build_hierarchy(w.patches(), w.materials(), w.caster(), ho));
  const HierarchyStats& st = h->stats();
  double oracle = 0.0, form_factors = 0.0, operators = 0.0, solves = 0.0;
  for (const auto& p : st.passes) {
    oracle += p.oracle_seconds;
    form_factors += p.form_factor_seconds;
    operators += p.operator_seconds;
    solves += p.solve_seconds;
  }
  sys.times.push_back({"hierarchy_exposure", st.exposure_seconds});
  sys.times.push_back({"hierarchy_oracle", oracle});
  sys.times.push_back({"hierarchy_form_factors", form_factors});
  sys.times.push_back({"hierarchy_operators", operators});
  sys.times.push_back({"hierarchy_pass_solves", solves});
  if (lobes) {
    sys.times.push_back({"hierarchy_root_form_factors", st.root_form_factor_seconds});
    sys.times.push_back({"specular_transfer", st.transfer_seconds});
    sys.times.push_back({"hierarchy_specular_links", st.specular_link_seconds});
  }
  sys.times.push_back({"hierarchy_lookup", st.lookup_seconds});
  sys.times.push_back({"hierarchy", st.seconds});
  Stopwatch watch;
  if (lobes) {
    // The lobe check reads the transfer's entries (no rays); then only their statistics stay.
    sys.lobes =
        check_lobe_resolution(w.scene(), w.patches(), h->root_form_factors(), h->root_transfer());
    sys.specular.stats = h->root_transfer().stats;
    h->release_transfer();
    sys.times.push_back({"lobe_check", watch.lap()});
  }
  sys.hierarchy = h;
  sys.transport = hierarchical_transport(h, w.materials());
  sys.times.push_back({"operator", watch.seconds()});
}

}  // namespace

std::unique_ptr<RadiositySystem> build_system(std::shared_ptr<const World> world,
                                              const SystemOptions& options) {
  const MemoryEstimate need = estimate_memory(*world, options);
  require_memory(need, memory_budget(options.max_memory_bytes), world->scene().file);
  auto sys = std::make_unique<RadiositySystem>();
  sys->estimated_memory = need;
  sys->world = std::move(world);
  const World& w = *sys->world;
  sys->times = w.times();
  if (options.mesh == MeshKind::kHierarchical) {
    build_hierarchical(*sys, options);
    return sys;
  }
  Stopwatch watch;
  sys->form_factors = compute_form_factors(w.patches(), w.caster(), options.form_factors);
  sys->times.push_back({"form_factors", watch.lap()});
  sys->specular = compute_specular_transfer(w.patches(), w.materials(), sys->form_factors,
                                            w.caster(), options.specular);
  sys->times.push_back({"specular_transfer", watch.lap()});
  // Before the on-the-fly mode releases the entries: the check reads them (no rays).
  sys->lobes = check_lobe_resolution(w.scene(), w.patches(), sys->form_factors, sys->specular);
  sys->times.push_back({"lobe_check", watch.lap()});
  if (options.specular_on_the_fly) {
    OnTheFlySpecular source{&w.patches(), &w.materials(), &sys->form_factors, &w.caster(),
                            options.specular};
    sys->transport =
        build_transport(w.patches(), w.materials(), sys->form_factors, &sys->specular, &source);
    SpecularStats stats = sys->specular.stats;
    sys->specular = SpecularTransfer{};  // its entries are recomputed when needed
    sys->specular.stats = stats;
  } else {
    sys->transport = build_transport(w.patches(), w.materials(), sys->form_factors, &sys->specular);
  }
  sys->times.push_back({"operator", watch.lap()});
  return sys;
}

std::unique_ptr<RadiositySystem> build_system(Scene scene, const SceneOverrides& overrides,
                                              const SystemOptions& options) {
  require_memory_before_meshing(estimate_memory(apply_overrides(scene, overrides), options),
                                memory_budget(options.max_memory_bytes), scene.file);
  // The world applies the overrides itself: it takes the scene as written.
  return build_system(World::build(std::move(scene), overrides), options);
}

}  // namespace polyrad
