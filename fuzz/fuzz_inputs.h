// What one fuzz input does, shared by the libFuzzer targets (fuzz/*_fuzzer.cpp) and by the
// GoogleTest that replays the corpus and every saved finding (tests/fuzz_regression_test.cpp).
//
// Each function feeds bytes to a stage of scene loading and lets exceptions escape: the caller
// decides what is allowed. Bad input may throw polyrad::InputError and nothing else; a crash, a
// sanitizer report or any other exception type is a finding.
//
//   polyrad::fuzz::scene_input(text);  // parse_scene_text, then resolve_scene if no mesh is used
//   polyrad::fuzz::obj_input(text);    // read_obj_text
//
// scene_input also checks what resolution promises (finite vertices, a normal per face) and
// throws std::logic_error when it does not hold.
//
// Cost: one parse of the input; resolution checks each polygon in O(n^2) of its vertices.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>

#include "polyrad/scene.h"

namespace polyrad::fuzz {

// What resolve_scene promises the mesher: finite vertices and a face normal that normalises.
// A face that breaks it was accepted when it should have been refused: a finding.
inline void check_faces(const Scene& scene) {
  for (const SceneObject& o : scene.objects)
    for (const Face& f : o.faces) {
      Vec3 normal = Vec3::Zero();
      for (size_t a = 0; a < f.vertices.size(); ++a) {
        if (!f.vertices[a].allFinite())
          throw std::logic_error("resolve_scene accepted a non-finite vertex in " + o.name);
        normal += f.vertices[a].cross(f.vertices[(a + 1) % f.vertices.size()]);
      }
      double length = normal.norm();
      if (f.vertices.size() < 3 || !std::isfinite(length) || !(length > 0.0))
        throw std::logic_error("resolve_scene accepted a face without a normal in " + o.name);
    }
}

// Stage 1 and, when the scene references no OBJ file, stage 2. A scene naming a mesh is not
// resolved: resolution would open whatever path the input names, and the OBJ reader has a
// target of its own.
inline void scene_input(const std::string& text) {
  SceneDesc desc = parse_scene_text(text, "fuzz.json");
  for (const ObjectDesc& o : desc.objects)
    if (!o.mesh.empty()) return;
  Scene scene = resolve_scene(desc);
  check_faces(scene);
}

inline void obj_input(const std::string& text) {
  std::vector<Face> faces = read_obj_text(text, "fuzz.obj");
  (void)faces;
}

}  // namespace polyrad::fuzz
