// The command line's shared pieces (flags.h).
#include "flags.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "polyrad/io/image_io.h"
#include "polyrad/util/files.h"
#include "polyrad/util/machine.h"

namespace polyrad::cli {

void check_output_path(const std::string& path, const char* what) {
  std::filesystem::path p(path);
  std::filesystem::path dir = p.parent_path();
  if (p.filename().empty()) throw InputError(std::string(what) + " '" + path + "' names no file");
  if (!dir.empty() && !std::filesystem::is_directory(dir))
    throw InputError(std::string(what) + " '" + path + "': directory '" + dir.string() +
                     "' does not exist");
  if (std::filesystem::is_directory(p))
    throw InputError(std::string(what) + " '" + path + "' is a directory");
}

void check_image_path(const std::string& path) {
  check_output_path(path, "image");
  if (!is_image_path(path))
    throw InputError("image '" + path + "': unknown format (use .exr, .pfm or .png)");
}

void write_report(const std::string& path, Report report) {
  if (path.empty()) return;
  report.peak_memory_bytes = std::max(report.peak_memory_bytes, peak_memory_bytes());
  write_file_atomic(path, to_json(report));
}

void print_warnings(const std::vector<LobeResolution>& lobes) {
  for (const auto& r : lobes)
    if (r.smeared) std::fprintf(stderr, "polyrad: warning: %s\n", describe_smear(r).c_str());
}

void print_warnings(const Report& report) {
  if (report.system) print_warnings(report.system->lobes);
  if (report.gather) {
    const std::string cut = describe_chain_cut(*report.gather);
    if (!cut.empty()) std::fprintf(stderr, "polyrad: warning: %s\n", cut.c_str());
  }
  for (const auto& [kind, message] : report.warnings)
    std::fprintf(stderr, "polyrad: warning: %s\n", message.c_str());
  if (!report.pathtrace) return;
  const std::string truncated = describe_truncation(*report.pathtrace);
  if (!truncated.empty()) std::fprintf(stderr, "polyrad: warning: %s\n", truncated.c_str());
}

namespace {

std::string number_text(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}

}  // namespace

void SystemFlags::add(CLI::App& app) {
  app.add_option("--patch-size", patch_size, "Override every patch_size of the scene")
      ->check(CLI::PositiveNumber);
  app.add_option("--specular-samples", specular_samples,
                 "Point pairs per link pair for the specular transfer")
      ->check(CLI::Range(1, 4096))
      ->capture_default_str();
  app.add_flag("--classic", classic,
               "Classic radiosity: every material reduced to its diffuse part");
  app.add_flag("--centre-point", centre_point,
               "Specular transfer by the seed's centre-point rho (for comparison only)");
  app.add_option(
         "--max-memory", max_memory_gib,
         "Refuse scenes estimated to need more memory than this, in GiB (default: 80% of RAM)")
      ->check(CLI::Range(1.0 / 1024, 1024.0 * 1024));  // a MiB to a PiB
  app.add_flag("--specular-on-the-fly", on_the_fly,
               "Recompute the specular transfer at every sweep instead of storing it");
  mesh_option = add_enum_option(
      app, "--mesh", mesh,
      "Uniform patches linked pair by pair, or element trees on them linked at the level the "
      "light needs (lobes on links between the trees' roots) (default: hierarchical behind the "
      "patch gather, or where a hierarchy's own option is given; uniform behind the final gather, "
      "where rows need the uniform mesh and where no gather reads the solution)");
  mesh_option->default_str("");
  const std::string tolerances =
      number_text(link_tolerance_for(GatherKind::kFinal)) + " behind the final gather (" +
      number_text(link_tolerance_for(GatherKind::kPatch)) + " with --indirect mesh), " +
      number_text(link_tolerance_for(GatherKind::kPatch)) + " behind the patch gather, " +
      number_text(kDefaultLinkTolerance) + " where no gather reads the solution";
  hierarchy_options.push_back(
      app.add_option(
             "--link-tolerance", hierarchy.link_tolerance,
             "Hierarchical mesh: the error a link may make, as a fraction of what it carries "
             "(default " +
                 tolerances + ")")
          ->check(CLI::Range(1e-9, 1e9)));
  hierarchy_options.push_back(
      app.add_option("--min-element-size", hierarchy.min_element_size,
                     "Hierarchical mesh: no element is split below this edge (default: an eighth "
                     "of its root patch)")
          ->check(CLI::PositiveNumber));
  hierarchy_options.push_back(
      app.add_option("--mirror-links", hierarchy.mirror_links,
                     "Hierarchical mesh: what a planar mirror shows a surface without a lobe on "
                     "links to the mirror images of the elements, refined as the light needs "
                     "(false: on the links between the roots)")
          ->capture_default_str());
  hierarchy_options.push_back(
      app.add_option("--refine-passes", hierarchy.passes,
                     "Hierarchical mesh: refinement passes after the first, each after a solve")
          ->check(CLI::Range(0, 100))
          ->capture_default_str());
  app.add_flag("--allow-unsafe-albedo", unsafe_albedo,
               "UNSAFE: accept materials whose albedo may exceed 1 (to test divergence detection)");
}

SceneOptions SystemFlags::scene() const {
  SceneOptions o;
  o.allow_unsafe_albedo = unsafe_albedo;
  return o;
}

SceneOverrides SystemFlags::overrides() const { return {patch_size, classic}; }

SystemOptions SystemFlags::system() const {
  SystemOptions o;
  o.specular.samples = specular_samples;
  if (centre_point) o.specular.estimator = SpecularEstimator::kCentrePoint;
  o.specular_on_the_fly = on_the_fly;
  o.max_memory_bytes = max_memory_gib * (1ull << 30);
  // --mesh given wins; a hierarchy's own option without it asks for the hierarchy (rather than
  // being ignored on a uniform mesh); else the workflow chooses (system_for_gather).
  const auto given = [](const CLI::Option* option) { return option && option->count() > 0; };
  if (given(mesh_option))
    o.mesh = mesh;
  else if (std::any_of(hierarchy_options.begin(), hierarchy_options.end(), given))
    o.mesh = MeshKind::kHierarchical;
  o.hierarchy = hierarchy;
  return o;
}

void GatherFlags::add(CLI::App& app) {
  const GatherOptions patch, final = GatherOptions::final_gather();
  auto both = [](double p, double f) {
    return " (default " + number_text(p) + " for the patch gather, " + number_text(f) +
           " for the final)";
  };
  auto final_only = [](double f) { return " (default " + number_text(f) + ")"; };
  // "default F, M with --indirect mesh" of a final-gather count, from a member of the options.
  const GatherOptions mesh_mode = GatherOptions::final_gather(IndirectMode::kMesh);
  auto final_and_mesh = [&](int GatherOptions::*count) {
    return "default " + number_text(final.*count) + ", " + number_text(mesh_mode.*count) +
           " with --indirect mesh";
  };
  add_enum_option(app, "--gather", kind,
                  "How pixels read the solution: final (direct light and first bounce per pixel, "
                  "the mesh one bounce away) or patch (each pixel reads the patches it sees)");
  add_enum_option(app, "--indirect", indirect,
                  "Final gather: where the light beyond the direct light comes from: rays (cosine "
                  "samples and reflector points reading the mesh one bounce away; default) or mesh "
                  "(the diffuse part's, from the unknown under each pixel's own point with its "
                  "direct light taken out: no rays read the mesh there, and the mesh's own error "
                  "is in the image)");
  app.add_option("--diffuse", diffuse,
                 "How B is read where the image meets a patch (patch gather, default smooth) or "
                 "where a gather sample lands (final gather, default flat: each patch's own mean, "
                 "which keeps the flux a sample reads)")
      ->check(CLI::IsMember(enum_names<DiffuseMode>()));
  app.add_option("--pixel-grid", pixel_grid,
                 "Sub-pixel rays per side" + both(patch.pixel_grid, final.pixel_grid))
      ->check(CLI::Range(1, 16));
  app.add_option("--lobe-samples", lobe_samples,
                 "Samples of a glossy lobe" + both(patch.lobe_samples, final.lobe_samples))
      ->check(CLI::Range(1, 4096));
  app.add_option("--light-samples", light_samples,
                 "Points on the lights per glossy hit (patch gather) or per sub-pixel ray's hit "
                 "(final gather), weighted against the BRDF samples (0: BRDF samples alone) "
                 "(default " +
                     number_text(patch.light_samples) + " for the patch gather, " +
                     number_text(final.light_samples) + " for the final, " +
                     number_text(mesh_mode.light_samples) + " with --indirect mesh)")
      ->check(CLI::Range(0, 4096));
  app.add_option("--gather-samples", gather_samples,
                 "Final gather: cosine samples of a diffuse surface per sub-pixel ray (default " +
                     number_text(final.gather_samples) + "; " +
                     number_text(mesh_mode.gather_samples) +
                     " with --indirect mesh, where they only find the lights)")
      ->check(CLI::Range(1, 4096));
  app.add_option("--near-samples", near_samples,
                 "Final gather: light points and cosine samples of the second gather where a "
                 "sample lands near the point it left (0: read the patch there)" +
                     final_only(final.near_samples))
      ->check(CLI::Range(0, 4096));
  app.add_option(
         "--reflector-samples", reflector_samples,
         "Final gather: points on the mirrors and glossy surfaces that send specular light, "
         "per hit with a diffuse part, weighted against the cosine samples (0: the cosine "
         "samples alone; " +
             final_and_mesh(&GatherOptions::reflector_samples) + ")")
      ->check(CLI::Range(0, 4096));
  app.add_option("--mirror-images", mirror_image_samples,
                 "Final gather: light points per hit with a diffuse part for the lamps' light "
                 "that planar mirrors reflect to it, seen at their mirror images (0: the mirrors' "
                 "specular links carry it; " +
                     final_and_mesh(&GatherOptions::mirror_image_samples) + ")")
      ->check(CLI::Range(0, 4096));
  app.add_option("--mirror-image-depth", mirror_image_depth,
                 "Final gather: the most planar mirrors between a hit and a lamp's image, back "
                 "and forth between two that face each other, and that a cosine sample reading "
                 "through a mirror follows on through (1: one mirror, the light of longer chains "
                 "on the mirrors' specular links; 1 with --indirect mesh, which reads that light "
                 "from the mesh)" +
                     final_only(final.mirror_image_depth))
      ->check(CLI::Range(1, 64));
  app.add_option("--mirror-chains", mirror_chain_budget,
                 "Final gather: the most chains of two or more facing mirrors drawn from a hit, "
                 "whole lengths at a time up to --mirror-image-depth (three or more mirrors that "
                 "face each other have many; longer chains stay on the links; 0: one mirror)" +
                     final_only(final.mirror_chain_budget))
      ->check(CLI::Range(0, 1000000));
  add_enum_option(app, "--through-mirrors", through_mirrors,
                  "Final gather: where a cosine sample or a point on the reflectors meets a "
                  "mirror, follow it through the mirror to what it shows: where the mirror "
                  "images give the lamps' light the mirror reflects (imaged), at every mirror "
                  "(always: the lamps seen in a mirror without images then found by the samples "
                  "alone, noisy where they look small), or never (read the mirror's specular "
                  "link, one value per pair of patches)");
  app.add_option("--near-distance", near_distance,
                 "Final gather: near means within this many diameters of the patch met, blended "
                 "out at twice the distance" +
                     final_only(final.near_distance))
      ->check(CLI::Range(0.0, 1e9));
  app.add_option("--mesh-near-distance", mesh_near_distance,
                 "Final gather with --indirect mesh: a point where one of up to 8 cosine probes, "
                 "this many times the diameter of the unknown under it long (on a hierarchy at "
                 "least half its root's), meets a surface is gathered by rays instead of read "
                 "from that unknown (0: read the mesh everywhere; default " +
                     number_text(mesh_mode.mesh_near_distance) + ")")
      ->check(CLI::Range(0.0, 1e9));
  app.add_option("--mesh-read", mesh_read,
                 "Final gather with --indirect mesh: how the mesh gives a point its light: "
                 "smooth (bilinear in the averages at the corners of the unknowns under it) or "
                 "flat (the mean of the one under it) (default " +
                     std::string(enum_name(mesh_mode.mesh_read)) + ")")
      ->check(CLI::IsMember(enum_names<DiffuseMode>()));
  app.add_option("--mesh-near-samples", mesh_near_samples,
                 "Final gather with --indirect mesh: cosine samples at such a point (default " +
                     number_text(mesh_mode.mesh_near_samples) + ")")
      ->check(CLI::Range(1, 4096));
}

GatherOptions GatherFlags::options() const {
  // CLI::Range lets NaN through, and NaN would read as "not given".
  if (std::isnan(near_distance) || std::isnan(mesh_near_distance))
    throw InputError("--near-distance and --mesh-near-distance take a number, not NaN");
  if (kind == GatherKind::kPatch && indirect == IndirectMode::kMesh)
    throw InputError("--indirect mesh is a final gather's: the patch gather reads the mesh alone");
  GatherOptions o =
      kind == GatherKind::kPatch ? GatherOptions{} : GatherOptions::final_gather(indirect);
  if (!diffuse.empty()) o.diffuse = enum_from_name<DiffuseMode>(diffuse);
  if (!mesh_read.empty()) o.mesh_read = enum_from_name<DiffuseMode>(mesh_read);
  if (pixel_grid > 0) o.pixel_grid = pixel_grid;
  if (lobe_samples > 0) o.lobe_samples = lobe_samples;
  if (light_samples >= 0) o.light_samples = light_samples;
  if (gather_samples > 0) o.gather_samples = gather_samples;
  if (near_samples >= 0) o.near_samples = near_samples;
  if (reflector_samples >= 0) o.reflector_samples = reflector_samples;
  if (mirror_image_samples >= 0) o.mirror_image_samples = mirror_image_samples;
  if (mirror_image_depth > 0) o.mirror_image_depth = mirror_image_depth;
  if (mirror_chain_budget >= 0) o.mirror_chain_budget = mirror_chain_budget;
  o.through_mirrors = through_mirrors;
  if (near_distance >= 0.0) o.near_distance = near_distance;
  if (mesh_near_distance >= 0.0) o.mesh_near_distance = mesh_near_distance;
  if (mesh_near_samples > 0) o.mesh_near_samples = mesh_near_samples;
  return o;
}

std::map<std::string, Rgb> parse_emissions(const std::vector<std::string>& texts) {
  std::map<std::string, Rgb> out;
  for (const auto& text : texts) {
    const auto eq = text.find('=');
    if (eq == std::string::npos || eq == 0)
      throw InputError("--emission expects NAME=R,G,B, got '" + text + "'");
    const std::string name = text.substr(0, eq);
    std::stringstream ss(text.substr(eq + 1));
    Rgb c;
    char comma1 = 0, comma2 = 0;
    if (!(ss >> c[0] >> comma1 >> c[1] >> comma2 >> c[2]) || comma1 != ',' || comma2 != ',' ||
        !ss.eof())
      throw InputError("--emission expects NAME=R,G,B with three numbers, got '" + text + "'");
    if ((c < 0.0).any() || !c.isFinite().all())
      throw InputError("--emission for '" + name + "' must be finite and not negative");
    if (out.count(name)) throw InputError("--emission names '" + name + "' twice");
    out[name] = c;
  }
  return out;
}

}  // namespace polyrad::cli
