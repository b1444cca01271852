// The main job on one scene, end to end: the workflow behind `polyrad demo` and
// ./scripts/demo.sh.
//
//   1. the glossy radiosity system of the scene (form factors, specular transfer, operator T);
//   2. the iterative solution and its image (the reference every faster method is tested against);
//   3. the precomputed truncated power series (view rows), written as a .prt file;
//   4. relighting with it: one sparse product per new light, timed against the iterative solve;
//   5. a path-traced reference, and the radiosity image compared with it.
// Everything lands in the output folder with report.json and summary.md.
//
//   DemoResult r = demo({.out = "out", .scene = "scenes/cornell-mirror-cube.json"});
//
// Cost: the system, a solve, a precompute, a few products and a path-traced image.
#pragma once

#include <string>

#include "polyrad/app/report.h"

namespace polyrad {

struct DemoOptions {
  std::string out = "out";
  std::string scene;  // required
  int spp = 256;      // of the path-traced reference
  int repeats = 21;   // the product is timed over this many (median)
};

struct DemoResult {
  Report report;
  std::string summary;  // summary.md's text
};

DemoResult demo(const DemoOptions& options);

}  // namespace polyrad
