// OBJ meshes: `v` and `f` statements into planar convex faces (docs/scene-format.md). `vn`,
// `vt`, `vp`, `g`, `o`, `s`, `usemtl` and `mtllib` are ignored; anything else is an InputError
// naming file and line. Faces keep their vertex order; triangles and quads alike are returned
// as they are (the mesher merges triangle pairs back into quads).
//
//   std::vector<Face> faces = read_obj_file("scenes/meshes/tall_block.obj");
//
// Cost: one pass over the text.
#pragma once

#include <string>
#include <vector>

#include "polyrad/types.h"

namespace polyrad {

// One planar convex polygon, counter-clockwise seen from its front.
struct Face {
  std::vector<Vec3> vertices;
  int source_line = 0;  // line of the OBJ file it came from; 0 for a scene polygon
};

std::vector<Face> read_obj_text(const std::string& text, const std::string& file);
std::vector<Face> read_obj_file(const std::string& path);

}  // namespace polyrad
