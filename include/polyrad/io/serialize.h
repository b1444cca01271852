// The JSON form of the records an operator file stores and reports repeat: the scene
// overrides, the gather's options, the precompute's report and the operator's metadata. One
// writer and one reader per type: the .prt header, every report (app/report.h) and the
// server's answers all go through these, so a field has one name everywhere and what is written
// reads back exactly (the writer keeps every bit of a double; a non-finite bound is written
// null and read back as +infinity).
//
//   JsonWriter w;
//   w.begin_object();
//   write_json(w, "series", q.report);
//   w.end_object();
//   SeriesReport back = read_series_report(parse_json(w.str(), "x").object[0].second);
//
// Readers throw InputError naming the field (its file:line:column in the text read).
// Cost: proportional to the record (the term norms and columns are its only arrays).
#pragma once

#include <string_view>
#include <vector>

#include "polyrad/render/camera_gather.h"
#include "polyrad/scene/scene.h"
#include "polyrad/solve/series_operator.h"
#include "polyrad/util/json.h"

namespace polyrad {

void write_json(JsonWriter& w, std::string_view key, const SceneOverrides& o);
SceneOverrides read_scene_overrides(const JsonValue& v);

void write_json(JsonWriter& w, std::string_view key, const GatherOptions& o);
GatherOptions read_gather_options(const JsonValue& v);

void write_json(JsonWriter& w, std::string_view key, const SeriesReport& r);
SeriesReport read_series_report(const JsonValue& v);

// The operator's metadata as members of the object being written: kinds, image size, its
// origin (scene file and hash, world options, gather) and columns, and the precompute's report
// under "report". Neither the values nor the unknowns' layout.
void write_operator_metadata(JsonWriter& w, const SeriesMetadata& q);
// Reads what write_operator_metadata wrote into q; num_patches bounds the columns' patches. Headers
// written before the overrides were recorded keep a top-level "patch_size" and the gather's
// "specular" (false: classic).
void read_operator_metadata(const JsonValue& header, int num_patches, SeriesMetadata& q);

void write_rgb(JsonWriter& w, std::string_view key, const Rgb& c);

}  // namespace polyrad
