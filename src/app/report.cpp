// The one report of every workflow (app/report.h).
#include "polyrad/app/report.h"

#include <cmath>
#include <cstdio>

#include "polyrad/io/serialize.h"
#include "polyrad/util/json.h"
#include "polyrad/util/machine.h"

namespace polyrad {

GatherSummary summarize(const GatherOptions& options, const GatherWork& cost) {
  return {options, cost.rays, cost.nnz, cost.bytes, cost.seconds, cost.mirror_chains};
}

GatherSummary summarize(const Gather& g, const GatherWork& work) {
  return summarize(g.options, gather_cost(g, work));
}

std::string describe_chain_cut(const GatherSummary& g) {
  const MirrorChainCount& c = g.mirror_chains;
  if (c.hits <= 0 || c.cut * 100 < c.hits) return "";
  char b[400];
  std::snprintf(b, sizeof b,
                "at %lld of %lld hits before mirrors that face each other (%.3g%%), "
                "--mirror-chains %d kept the chains of mirrors only up to %d (of "
                "--mirror-image-depth %d): the lamps' light through longer chains stays on the "
                "mirrors' links, which spread it; raise --mirror-chains to take more, at more time",
                c.cut, c.hits, 100.0 * static_cast<double>(c.cut) / static_cast<double>(c.hits),
                g.options.mirror_chain_budget, c.shortest_cut, g.options.mirror_image_depth);
  return b;
}

double mean_relative_standard_error(const PathTraceResult& r) {
  if (r.standard_error.rgb.empty()) return std::nan("");
  double sum = 0.0;
  long long lit = 0;
  for (int y = 0; y < r.image.height; ++y)
    for (int x = 0; x < r.image.width; ++x) {
      const double l = luminance(r.image.at(x, y));
      if (l <= 0.0) continue;
      sum += luminance(r.standard_error.at(x, y)) / l;
      ++lit;
    }
  return lit > 0 ? sum / static_cast<double>(lit) : std::nan("");
}

PathTraceSummary summarize(const PathTraceResult& r, const PathTraceOptions& o) {
  PathTraceSummary s;
  s.width = r.image.width;
  s.height = r.image.height;
  s.spp = o.spp;
  s.max_depth = o.max_depth;
  s.seed = o.seed;
  s.stats = r.stats;
  s.seconds = r.seconds;
  s.mean_relative_standard_error = mean_relative_standard_error(r);
  return s;
}

std::string describe_truncation(const PathTraceSummary& p) {
  if (p.stats.paths <= 0 || p.stats.truncated * 10000 < p.stats.paths) return "";
  char b[320];
  std::snprintf(b, sizeof b,
                "%lld of %lld paths (%.3g%%) were cut at max_depth %d segments still carrying "
                "light, so the image is dark by what they would have gathered; raise --max-depth",
                p.stats.truncated, p.stats.paths,
                100.0 * static_cast<double>(p.stats.truncated) / static_cast<double>(p.stats.paths),
                p.max_depth);
  return b;
}

void Report::finish() {
  peak_memory_bytes = ::polyrad::peak_memory_bytes();
  machine = machine_description();
}

namespace {

void write_lobe_fields(JsonWriter& w, const LobeResolution& r) {
  w.value("object", r.object_name).value("material", r.material_name).value("lobe", r.lobe);
  w.value("lobe_width_degrees", r.lobe_degrees).value("patch_angle_degrees", r.patch_degrees);
  w.value("patch_size", r.current_patch_size);
  w.value("resolving_patch_size", r.resolving_patch_size);
}

void write_lobe_warnings(JsonWriter& w, const std::vector<LobeResolution>& lobes) {
  for (const auto& r : lobes) {
    if (!r.smeared) continue;
    w.begin_object().value("kind", "lobe_smeared_by_patches");
    write_lobe_fields(w, r);
    w.value("message", describe_smear(r)).end_object();
  }
}

void write_chain_warning(JsonWriter& w, const GatherSummary& g) {
  const std::string message = describe_chain_cut(g);
  if (message.empty()) return;
  w.begin_object().value("kind", "mirror_chains_cut_by_budget");
  w.value("hits", g.mirror_chains.hits).value("hits_cut", g.mirror_chains.cut);
  w.value("shortest_chain_kept", g.mirror_chains.shortest_cut);
  w.value("message", message).end_object();
}

void write_truncation_warning(JsonWriter& w, const PathTraceSummary& p) {
  const std::string message = describe_truncation(p);
  if (message.empty()) return;
  w.begin_object().value("kind", "paths_truncated");
  w.value("paths", p.stats.paths).value("paths_truncated", p.stats.truncated);
  w.value("max_depth", p.max_depth).value("message", message).end_object();
}

void write_lobe_checks(JsonWriter& w, const std::vector<LobeResolution>& lobes) {
  w.begin_array("lobe_resolution");
  for (const auto& r : lobes) {
    w.begin_object();
    write_lobe_fields(w, r);
    w.value("smeared", r.smeared).end_object();
  }
  w.end_array();
}

// ---- report sections -------------------------------------------------------------------------

void write_json(JsonWriter& w, std::string_view key, const StageTimes& times) {
  w.begin_object(key);
  for (const auto& t : times) w.value(t.name, t.seconds);
  w.end_object();
}

void write_json(JsonWriter& w, std::string_view key, const SolveResult& r) {
  w.begin_object(key);
  w.value("solver", enum_name(r.method));
  w.value("status", enum_name(r.status));
  w.value("iterations", r.iterations);
  w.value("residual", r.residual);
  w.value("seconds", r.seconds);
  if (!r.message.empty()) w.value("message", r.message);
  w.begin_array("sweep_residuals");
  for (double x : r.sweep_residual) w.element(x);
  w.end_array();
  w.end_object();
}

void write_json(JsonWriter& w, std::string_view key, const ImageComparison& c) {
  w.begin_object(key);
  w.value("width", c.width).value("height", c.height);
  write_rgb(w, "epsilon", c.epsilon);
  w.value("relative_rmse", c.relative_rmse);
  w.value("relative_l1", c.relative_l1);
  w.value("mean_relative_error", c.mean_relative_error);
  w.value("normalized_rmse", c.normalized_rmse);
  write_rgb(w, "mean_a", c.mean_a);
  write_rgb(w, "mean_b", c.mean_b);
  if (!c.regions.empty()) {
    w.value("worst_region_difference", c.worst_region_difference);
    w.value("pixels_without_region", c.pixels_without_region);
    w.begin_array("regions");
    for (const auto& r : c.regions) {
      w.begin_object();
      w.value("name", r.name).value("pixels", r.pixels);
      write_rgb(w, "mean_a", r.mean_a);
      write_rgb(w, "mean_b", r.mean_b);
      write_rgb(w, "relative_difference", r.relative_difference);
      w.value("luminance_difference", r.luminance_difference);
      w.value("relative_l1", r.relative_l1);
      w.end_object();
    }
    w.end_array();
  }
  w.begin_array("worst_pixels");
  for (const auto& p : c.worst) {
    w.begin_object();
    w.value("x", p.x).value("y", p.y);
    write_rgb(w, "a", p.a);
    write_rgb(w, "b", p.b);
    w.value("error", p.error);
    w.end_object();
  }
  w.end_array();
  w.end_object();
}

void write_json(JsonWriter& w, std::string_view key, const HierarchySummary& h) {
  const HierarchyStats& st = h.stats;
  w.begin_object(key)
      .value("roots", h.roots)
      .value("elements", h.elements)
      .value("leaves", h.leaves)
      .value("links", h.links)
      .value("link_entries", h.link_entries)
      .value("link_tolerance", st.link_tolerance)
      .value("b_ref_estimate", st.b_ref_estimate)
      .value("b_ref", st.b_ref)
      .value("root_pairs_facing", st.root_pairs_facing)
      .value("oracle_rays", st.oracle_rays)
      .value("form_factor_rays", st.form_factor_rays)
      .value("exposure_seconds", st.exposure_seconds)
      .value("guard_max_excess", st.guard_max_excess)
      .value("guard_leaves", st.guard_leaves)
      .value("root_form_factors", st.root_form_factors)
      .value("transfer_entries", st.transfer_entries)
      .value("specular_links", st.specular_links)
      .value("specular_row_entries", st.specular_row_entries)
      .value("mirror_planes", st.mirror_planes)
      .value("image_links", st.image_links)
      .value("root_form_factor_seconds", st.root_form_factor_seconds)
      .value("transfer_seconds", st.transfer_seconds)
      .value("specular_link_seconds", st.specular_link_seconds)
      .value("lookup_seconds", st.lookup_seconds)
      .value("operator_bytes", h.operator_bytes)
      .value("seconds", st.seconds);
  w.begin_array("passes");
  for (const auto& p : st.passes)
    w.begin_object()
        .value("candidates", p.candidates)
        .value("visibility_tests", p.visibility_tests)
        .value("splits", p.splits)
        .value("elements", p.elements)
        .value("leaves", p.leaves)
        .value("links", p.links)
        .value("sweeps", p.sweeps)
        .value("oracle_seconds", p.oracle_seconds)
        .value("form_factor_seconds", p.form_factor_seconds)
        .value("operator_seconds", p.operator_seconds)
        .value("solve_seconds", p.solve_seconds)
        .end_object();
  w.end_array();
  w.end_object();
}

void write_json(JsonWriter& w, std::string_view key, const SystemSummary& s) {
  w.begin_object(key);
  w.value("mesh", enum_name(s.mesh));
  if (s.hierarchy) write_json(w, "hierarchy", *s.hierarchy);
  w.value("patches", s.patches);
  w.value("links", s.links);
  w.value("unknowns", s.unknowns);
  w.begin_object("form_factors")
      .value("pairs_facing", s.form_factors.pairs_facing)
      .value("pairs_visible", s.form_factors.pairs_visible)
      .value("rays", s.form_factors.rays)
      .value("nnz", s.form_factor_nnz)
      .value("bytes", s.form_factor_bytes)
      .value("seconds", s.form_factors.seconds)
      .end_object();
  w.begin_object("specular_transfer")
      .value("link_pairs", s.specular.pairs)
      .value("entries", s.specular_entries)
      .value("rays", s.specular.rays)
      .value("pairs_unseen", s.specular.pairs_unseen)
      .value("dropped_hits", s.specular.dropped_hits)
      .value("balance_residual", s.specular.balance_mismatch)
      .value("escaped_fraction", s.specular.escaped_fraction)
      .value("bytes", s.specular_bytes)
      .value("seconds", s.specular.seconds)
      .end_object();
  w.begin_object("operator")
      .value("on_the_fly", s.on_the_fly)
      .value("nnz_diffuse", s.nnz_diffuse)
      .value("nnz_specular", s.nnz_specular)
      .value("bytes", s.operator_bytes)
      .value("max_albedo", s.max_albedo)
      .end_object();
  write_lobe_checks(w, s.lobes);
  // The total, and its parts (memory_estimate.h) to tell which one a peak outgrew.
  const MemoryEstimate& m = s.estimated_memory;
  w.value("estimated_memory_bytes", m.total());
  w.begin_object("estimated_memory")
      .value("base_bytes", m.base)
      .value("world_bytes", m.world)
      .value("system_bytes", m.system)
      .value("camera_bytes", m.camera)
      .value("patches", m.patches)
      .value("visible_pairs", m.visible_pairs)
      .end_object();
  w.end_object();
}

void write_gather(JsonWriter& w, const GatherSummary& g) {
  w.begin_object("gather");
  write_json(w, "options", g.options);
  w.value("rays", g.rays).value("nnz", g.nnz).value("bytes", g.bytes).value("seconds", g.seconds);
  if (g.mirror_chains.hits > 0) {
    w.begin_object("mirror_chains");
    w.value("hits", g.mirror_chains.hits).value("hits_cut", g.mirror_chains.cut);
    w.value("shortest_chain_kept", g.mirror_chains.shortest_cut).end_object();
  }
  w.end_object();
}

void write_series(JsonWriter& w, const SeriesMetadata& m) {
  w.begin_object("series");
  write_operator_metadata(w, m);
  w.end_object();
}

void write_pathtrace(JsonWriter& w, const PathTraceSummary& p) {
  w.begin_object("pathtrace");
  w.value("width", p.width).value("height", p.height);
  w.value("spp", p.spp)
      .value("seed", static_cast<long long>(p.seed))
      .value("max_depth", p.max_depth);
  w.value("paths", p.stats.paths)
      .value("rays", p.stats.rays)
      .value("paths_truncated", p.stats.truncated);
  w.value("rays_per_second", p.seconds > 0.0 ? static_cast<double>(p.stats.rays) / p.seconds : 0.0);
  w.value("mean_relative_standard_error", p.mean_relative_standard_error);
  w.value("seconds", p.seconds);
  w.end_object();
}

void write_relight(JsonWriter& w, const RelightSummary& r) {
  w.begin_object("relight");
  w.begin_object("emission");
  for (const auto& [name, rgb] : r.emission) write_rgb(w, name, rgb);
  w.end_object();
  w.value("product_seconds_median", r.product.median);
  w.value("product_seconds_min", r.product.min);
  w.value("product_repeats", r.product.repeats);
  w.value("bytes_touched", r.bytes_touched);
  w.value("bytes_per_second", r.product.median > 0.0 ? r.bytes_touched / r.product.median : 0.0);
  w.value("gather_seconds", r.gather_seconds);
  w.end_object();
}

}  // namespace

std::string to_json(const Report& r) {
  JsonWriter w;
  w.begin_object();
  w.value("command", r.command);
  if (!r.method.empty()) w.value("method", r.method);
  if (!r.scene.empty()) w.value("scene", r.scene);
  if (!r.inputs.empty()) {
    w.begin_object("inputs");
    for (const auto& [role, path] : r.inputs) w.value(role, path);
    w.end_object();
  }
  if (r.overrides) write_json(w, "overrides", *r.overrides);
  w.begin_array("warnings");
  if (r.system) write_lobe_warnings(w, r.system->lobes);
  if (r.pathtrace) write_truncation_warning(w, *r.pathtrace);
  if (r.gather) write_chain_warning(w, *r.gather);
  for (const auto& [kind, message] : r.warnings)
    w.begin_object().value("kind", kind).value("message", message).end_object();
  w.end_array();
  if (r.system) write_json(w, "system", *r.system);
  if (r.solve) write_json(w, "solve", *r.solve);
  if (r.gather) write_gather(w, *r.gather);
  if (r.series) write_series(w, *r.series);
  if (r.pathtrace) write_pathtrace(w, *r.pathtrace);
  if (r.relight) write_relight(w, *r.relight);
  if (r.comparison) write_json(w, "comparison", *r.comparison);
  if (!r.figures.empty()) {
    w.begin_object("figures");
    for (const auto& [name, x] : r.figures) w.value(name, x);
    w.end_object();
  }
  write_json(w, "seconds", r.seconds);
  w.value("peak_memory_bytes", r.peak_memory_bytes);
  w.value("machine", r.machine);
  w.end_object();
  return w.str();
}

}  // namespace polyrad
