// The JSON of the relighting API (README, "polyrad serve"): requests read with polyrad's JSON
// reader (json.h), so that a bad request is an InputError naming line and column, and the
// answers the server writes.
//
//   RelightRequest r = parse_relight_request(R"({"emission": {"light": [34, 24, 8]}})", relighter);
//   relighter.relight(r.emission, r.orbit);
//
// Cost: one pass over the request; requests are small (the server refuses bodies over 1 MiB).
#pragma once

#include <map>
#include <string>
#include <string_view>

#include "polyrad/app/relight.h"

namespace polyrad::serve {

enum class ImageFormat { kPng, kPfm };

struct RelightRequest {
  std::map<std::string, Rgb> emission;  // only the lights named; the others keep the scene's
  double exposure = 1.0;                // PNG only: radiance x exposure before the tonemap
  ImageFormat format = ImageFormat::kPng;
  Orbit orbit;  // "camera": {"yaw": deg, "pitch": deg}, solution operators
};

// {"emission": {"NAME": [r, g, b], ...}, "exposure": E, "format": "png" | "pfm",
//  "camera": {"yaw": Y, "pitch": P}}, every key optional. Throws InputError for malformed JSON,
// unknown keys, an unknown light, a negative value, an array not of 3 numbers, an exposure not
// above 0, an unknown format, or a camera given to a view operator. (Non-finite numbers are
// not JSON, and the reader refuses those that overflow.)
RelightRequest parse_relight_request(std::string_view body, const Relighter& relighter);

// GET /api/operator: {"lights": [{"name", "emission": [r, g, b]}], "width", "height",
// "output": "view" | "solution", "order", "bytes", "columns", "nnz", "precision", "orbit"}.
std::string operator_json(const Relighter& relighter);

// {"error": message}
std::string error_json(std::string_view message);

}  // namespace polyrad::serve
