// The relighting API's JSON (relight_request.h).
#include "polyrad/serve/relight_request.h"

#include <algorithm>
#include <cmath>

#include "polyrad/util/json.h"

namespace polyrad::serve {

namespace {

constexpr const char* kRequestName = "request";  // what error locations call the body

std::string light_list(const Relighter& r) {
  std::string names;
  for (const Light& l : r.lights()) names += (names.empty() ? "" : ", ") + l.name;
  return names;
}

Rgb read_rgb(const JsonValue& v, const std::string& light) {
  std::vector<double> c = json_numbers(v, "the emission of '" + light + "'", 3);
  for (double x : c)
    if (!(x >= 0.0) || !std::isfinite(x))
      throw InputError(v.where, "the emission of '" + light + "' must be finite and not negative");
  return Rgb(c[0], c[1], c[2]);
}

std::map<std::string, Rgb> read_emission(const JsonValue& v, const Relighter& r) {
  if (!v.is(JsonValue::Kind::kObject))
    throw InputError(v.where, "'emission' must be an object of NAME: [r, g, b]");
  std::map<std::string, Rgb> out;
  for (const auto& entry : v.object) {
    // Named, not a structured binding: Clang 14 (the sanitizer build) cannot capture one.
    const std::string& name = entry.first;
    const JsonValue& value = entry.second;
    const auto& lights = r.lights();
    if (std::none_of(lights.begin(), lights.end(), [&](const Light& l) { return l.name == name; }))
      throw InputError(value.where, "'" + name + "' is not a light of this operator (lights: " +
                                        light_list(r) + ")");
    out[name] = read_rgb(value, name);
  }
  return out;
}

ImageFormat read_format(const JsonValue& v) {
  if (v.is(JsonValue::Kind::kString) && v.string == "png") return ImageFormat::kPng;
  if (v.is(JsonValue::Kind::kString) && v.string == "pfm") return ImageFormat::kPfm;
  throw InputError(v.where, "'format' must be \"png\" or \"pfm\"");
}

Orbit read_orbit(const JsonValue& v, const Relighter& r) {
  if (!r.can_orbit())
    throw InputError(
        v.where, "a view operator's camera is fixed: precompute with --output solution to orbit");
  ObjectReader c(v, "'camera'");
  Orbit o;
  o.yaw_degrees = c.optional_number("yaw").value_or(0.0);
  o.pitch_degrees = c.optional_number("pitch").value_or(0.0);
  c.finish();
  if (std::abs(o.yaw_degrees) > 1e6 || std::abs(o.pitch_degrees) > 1e6)
    throw InputError(v.where, "'camera' angles must be within a million degrees");
  return o;
}

}  // namespace

RelightRequest parse_relight_request(std::string_view body, const Relighter& relighter) {
  const JsonValue root = parse_json(body, kRequestName);
  ObjectReader reader(root, "the request");
  RelightRequest req;
  if (const JsonValue* e = reader.optional("emission")) req.emission = read_emission(*e, relighter);
  if (const JsonValue* x = reader.optional("exposure")) {
    req.exposure = json_number(*x, "'exposure'");
    if (!(req.exposure > 0.0)) throw InputError(x->where, "'exposure' must be above 0");
  }
  if (const JsonValue* f = reader.optional("format")) req.format = read_format(*f);
  if (const JsonValue* c = reader.optional("camera")) req.orbit = read_orbit(*c, relighter);
  reader.finish();
  return req;
}

std::string operator_json(const Relighter& r) {
  const SeriesOperator& q = r.op();
  JsonWriter w;
  w.begin_object();
  w.begin_array("lights");
  for (const Light& l : r.lights()) {
    w.begin_object().value("name", l.name).begin_array("emission");
    for (int c = 0; c < 3; ++c) w.element(l.emission[c]);
    w.end_array().end_object();
  }
  w.end_array();
  w.value("width", r.width()).value("height", r.height());
  w.value("output", enum_name(r.output()));
  w.value("order", q.report.order);
  w.value("bytes", q.bytes());
  w.value("columns", static_cast<long long>(q.cols()));
  w.value("nnz", static_cast<long long>(q.nnz()));
  w.value("precision", enum_name(q.precision));
  w.value("orbit", r.can_orbit());
  w.end_object();
  return w.str();
}

std::string error_json(std::string_view message) {
  return "{\"error\": " + json_escape(message) + "}";
}

}  // namespace polyrad::serve
