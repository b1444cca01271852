// The JSON form of polyrad's records (io/serialize.h).
#include "polyrad/io/serialize.h"

#include <cmath>

namespace polyrad {

namespace {

// An enum read by its table's name; InputError at the value for an unknown one.
template <typename E>
E read_enum(ObjectReader& r, std::string_view key) {
  const JsonValue& v = r.get(key);
  if (!v.is(JsonValue::Kind::kString))
    throw InputError(v.where, "'" + std::string(key) + "' must be a string");
  try {
    return enum_from_name<E>(v.string);
  } catch (const InputError& e) {
    throw InputError(v.where, e.message());
  }
}

SeriesColumn read_column(const JsonValue& v, int num_patches) {
  ObjectReader r(v, "a column");
  SeriesColumn c;
  c.object = r.string("object");
  c.patch = static_cast<PatchId>(r.integer("patch", -1, num_patches - 1));
  const auto e = json_numbers(r.get("emission"), "a column's emission", 3);
  c.emission = Rgb(e[0], e[1], e[2]);
  return c;
}

}  // namespace

void write_rgb(JsonWriter& w, std::string_view key, const Rgb& c) {
  w.begin_array(key);
  for (int k = 0; k < 3; ++k) w.element(c[k]);
  w.end_array();
}

// ---- options and the operator's header -------------------------------------------------------

void write_json(JsonWriter& w, std::string_view key, const SceneOverrides& o) {
  w.begin_object(key).value("patch_size", o.patch_size).value("classic", o.classic).end_object();
}

SceneOverrides read_scene_overrides(const JsonValue& v) {
  ObjectReader r(v, "the scene overrides");
  SceneOverrides o;
  o.patch_size = r.number("patch_size");
  if (!(o.patch_size >= 0.0 && o.patch_size < 1e300))
    throw InputError(v.where, "the patch size is out of range");
  o.classic = r.boolean("classic");
  return o;
}

void write_json(JsonWriter& w, std::string_view key, const GatherOptions& o) {
  w.begin_object(key)
      .value("kind", enum_name(o.kind))
      .value("diffuse", enum_name(o.diffuse))
      .value("pixel_grid", o.pixel_grid)
      .value("lobe_samples", o.lobe_samples)
      .value("light_samples", o.light_samples)
      .value("gather_samples", o.gather_samples)
      .value("mirror_depth", o.mirror_depth)
      .value("emission_grid", o.emission_grid)
      .value("emission_grid_everywhere", o.emission_grid_everywhere)
      .value("near_samples", o.near_samples)
      .value("near_distance", o.near_distance)
      .value("reflector_samples", o.reflector_samples)
      .value("mirror_image_samples", o.mirror_image_samples)
      .value("mirror_image_depth", o.mirror_image_depth)
      .value("mirror_chain_budget", o.mirror_chain_budget)
      .value("through_mirrors", enum_name(o.through_mirrors))
      .value("indirect", enum_name(o.indirect))
      .value("mesh_near_distance", o.mesh_near_distance)
      .value("mesh_near_samples", o.mesh_near_samples)
      .value("mesh_read", enum_name(o.mesh_read))
      .value("seed", static_cast<long long>(o.seed))
      .end_object();
}

GatherOptions read_gather_options(const JsonValue& v) {
  ObjectReader r(v, "the gather options");
  GatherOptions o;
  // Written before samples followed their rays through mirrors: the mirrors' links read.
  o.through_mirrors = ThroughMirrors::kNever;
  o.diffuse = read_enum<DiffuseMode>(r, "diffuse");
  o.pixel_grid = static_cast<int>(r.integer("pixel_grid", 1, 16));
  o.lobe_samples = static_cast<int>(r.integer("lobe_samples", 1, 4096));
  // Written before the gather sampled the lights: it sampled none.
  o.light_samples =
      r.has("light_samples") ? static_cast<int>(r.integer("light_samples", 0, 4096)) : 0;
  o.seed = static_cast<std::uint64_t>(r.integer("seed", 0, 9e15));
  // Written before the final gather existed: a patch gather, the counts unused.
  if (r.has("kind")) {
    o.kind = read_enum<GatherKind>(r, "kind");
    o.gather_samples = static_cast<int>(r.integer("gather_samples", 1, 65536));
    o.mirror_depth = static_cast<int>(r.integer("mirror_depth", 0, 64));
    o.emission_grid = static_cast<int>(r.integer("emission_grid", 1, 16));
    // Written before the finer rays were cast only where needed: everywhere.
    o.emission_grid_everywhere =
        !r.has("emission_grid_everywhere") || r.boolean("emission_grid_everywhere");
    o.near_samples = static_cast<int>(r.integer("near_samples", 0, 65536));
    o.near_distance = r.number("near_distance");
    if (!(o.near_distance >= 0.0 && o.near_distance < 1e300))
      throw InputError(v.where, "the gather's near_distance is out of range");
    // Written before the final gather drew points on the reflectors: it drew none.
    if (r.has("reflector_samples"))
      o.reflector_samples = static_cast<int>(r.integer("reflector_samples", 0, 65536));
    // Written before the final gather drew the mirrors' images of the lamps: it drew none.
    if (r.has("mirror_image_samples"))
      o.mirror_image_samples = static_cast<int>(r.integer("mirror_image_samples", 0, 65536));
    // Written before the images went through more than one mirror: one.
    if (r.has("mirror_image_depth"))
      o.mirror_image_depth = static_cast<int>(r.integer("mirror_image_depth", 1, 64));
    // Written before the chains went past two planes that take turns: the default (with two
    // facing mirrors the same chains; among three or more, those files drew fewer).
    if (r.has("mirror_chain_budget"))
      o.mirror_chain_budget = static_cast<int>(r.integer("mirror_chain_budget", 0, 1000000));
    if (r.has("through_mirrors"))
      o.through_mirrors = read_enum<ThroughMirrors>(r, "through_mirrors");
    // Written before the indirect light could come from the mesh: from rays.
    if (r.has("indirect")) o.indirect = read_enum<IndirectMode>(r, "indirect");
    // Written before the mesh's near points were gathered by rays: the mesh read everywhere.
    if (r.has("mesh_near_distance")) {
      o.mesh_near_distance = r.number("mesh_near_distance");
      if (!(o.mesh_near_distance >= 0.0 && o.mesh_near_distance < 1e300))
        throw InputError(v.where, "the gather's mesh_near_distance is out of range");
      o.mesh_near_samples = static_cast<int>(r.integer("mesh_near_samples", 1, 65536));
    }
    // Written before the mesh's read at a point had its own mode: the diffuse mode's.
    o.mesh_read = r.has("mesh_read") ? read_enum<DiffuseMode>(r, "mesh_read") : o.diffuse;
  }
  r.optional("specular");  // the classic flag of old headers (read_operator_metadata)
  return o;
}

void write_json(JsonWriter& w, std::string_view key, const SeriesReport& r) {
  w.begin_object(key)
      .value("order", r.order)
      .value("max_albedo", r.max_albedo)
      .value("apriori_bound", r.apriori_bound)
      .value("aposteriori_estimate", r.aposteriori_estimate)
      .value("spectral_radius", r.spectral_radius)
      .value("acceleration", enum_name(r.acceleration))
      .value("chebyshev_radius", r.chebyshev_radius)
      .value("residual_bound", r.residual_bound)
      .value("dropped_energy", r.dropped_energy)
      .value("dropped_relative", r.dropped_relative)
      .value("nnz", r.nnz)
      .value("bytes", r.bytes)
      .value("seconds", r.seconds)
      .value("reorder", enum_name(r.reorder))
      .value("bandwidth_before", r.bandwidth_before)
      .value("bandwidth_after", r.bandwidth_after)
      .value("reorder_seconds", r.reorder_seconds)
      .value("gather_seconds", r.gather.seconds);
  w.begin_array("term_norms");
  for (double x : r.term_norms) w.element(x);
  w.end_array().end_object();
}

SeriesReport read_series_report(const JsonValue& v) {
  ObjectReader r(v, "the series report");
  SeriesReport s;
  s.order = static_cast<int>(r.integer("order", 0, 1e9));
  s.max_albedo = r.number("max_albedo");
  s.apriori_bound = r.number_or_infinity("apriori_bound");
  s.aposteriori_estimate = r.number_or_infinity("aposteriori_estimate");
  s.spectral_radius = r.number("spectral_radius");
  s.dropped_energy = r.number("dropped_energy");
  s.dropped_relative = r.number("dropped_relative");
  s.seconds = r.number("seconds");
  for (const auto& x : r.array("term_norms").array)
    s.term_norms.push_back(x.is(JsonValue::Kind::kNumber) ? x.number : INFINITY);
  // Fields written since the first version of the file; older headers lack them.
  if (r.has("acceleration")) {
    s.acceleration = read_enum<SeriesAcceleration>(r, "acceleration");
    s.chebyshev_radius = r.number("chebyshev_radius");
    s.residual_bound = r.number_or_infinity("residual_bound");
  }
  if (r.has("nnz")) {
    s.nnz = r.integer("nnz", 0, 9e15);
    s.bytes = static_cast<std::size_t>(r.integer("bytes", 0, 9e15));
    s.gather.seconds = r.number("gather_seconds");
  }
  if (r.has("reorder")) {
    s.reorder = read_enum<SeriesReorder>(r, "reorder");
    s.bandwidth_before = r.integer("bandwidth_before", 0, 9e15);
    s.bandwidth_after = r.integer("bandwidth_after", 0, 9e15);
    s.reorder_seconds = r.number("reorder_seconds");
  }
  return s;
}

void write_operator_metadata(JsonWriter& w, const SeriesMetadata& q) {
  w.value("scene_file", q.scene_file);
  w.value("scene_hash", std::to_string(q.scene_hash));
  write_json(w, "overrides", q.overrides);
  w.value("output", enum_name(q.output));
  w.value("basis", enum_name(q.basis));
  w.value("precision", enum_name(q.precision));
  w.value("width", q.width).value("height", q.height);
  write_json(w, "gather", q.gather);
  w.begin_array("columns");
  for (const auto& c : q.columns) {
    w.begin_object().value("object", c.object).value("patch", c.patch);
    write_rgb(w, "emission", c.emission);
    w.end_object();
  }
  w.end_array();
  write_json(w, "report", q.report);
}

void read_operator_metadata(const JsonValue& header, int num_patches, SeriesMetadata& q) {
  ObjectReader r(header, "the operator header");
  q.scene_file = r.string("scene_file");
  const JsonValue& hash = r.get("scene_hash");
  try {
    size_t used = 0;
    if (!hash.is(JsonValue::Kind::kString)) throw std::invalid_argument("not a string");
    q.scene_hash = std::stoull(hash.string, &used);
    if (used != hash.string.size()) throw std::invalid_argument(hash.string);
  } catch (const std::exception&) {
    throw InputError(hash.where, "the scene hash is malformed");
  }
  q.output = read_enum<SeriesOutput>(r, "output");
  q.basis = read_enum<SeriesBasis>(r, "basis");
  q.precision = read_enum<ValuePrecision>(r, "precision");
  q.width = static_cast<int>(r.integer("width", 0, 1 << 16));
  q.height = static_cast<int>(r.integer("height", 0, 1 << 16));
  const JsonValue& gather = r.object("gather");
  q.gather = read_gather_options(gather);
  if (r.has("overrides")) {
    q.overrides = read_scene_overrides(r.object("overrides"));
  } else {  // written before the overrides were: a top-level patch size, classic as no specular
    q.overrides.patch_size = r.has("patch_size") ? r.number("patch_size") : 0.0;
    if (!(q.overrides.patch_size >= 0.0 && q.overrides.patch_size < 1e300))
      throw InputError(header.where, "the patch size is out of range");
    const JsonValue* specular = gather.find("specular");
    q.overrides.classic = specular && specular->is(JsonValue::Kind::kBool) && !specular->boolean;
  }
  q.columns.clear();
  for (const auto& c : r.array("columns").array) q.columns.push_back(read_column(c, num_patches));
  q.report = read_series_report(r.object("report"));
}

}  // namespace polyrad
