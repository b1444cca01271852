// Wavefront OBJ: only what patches need (positions and faces).
#include "polyrad/scene/obj_reader.h"

#include <charconv>
#include <cmath>
#include <sstream>

#include "polyrad/util/error.h"
#include "polyrad/util/files.h"

namespace polyrad {

namespace {

// Parses the vertex index of one face corner ("7", "7/2", "7//3", "-1/..."), 1-based or
// negative (relative to the end), into a 0-based index.
long parse_corner(const std::string& token, long vertex_count, const SourceLocation& where) {
  std::string head = token.substr(0, token.find('/'));
  long index = 0;
  auto [end, ec] = std::from_chars(head.data(), head.data() + head.size(), index);
  if (ec != std::errc() || end != head.data() + head.size() || index == 0)
    throw InputError(where, "OBJ: invalid face vertex '" + token + "'");
  long resolved = index > 0 ? index - 1 : vertex_count + index;
  if (resolved < 0 || resolved >= vertex_count)
    throw InputError(where, "OBJ: face vertex " + std::to_string(index) + " does not exist (" +
                                std::to_string(vertex_count) + " vertices so far)");
  return resolved;
}

}  // namespace

std::vector<Face> read_obj_text(const std::string& text, const std::string& file) {
  std::vector<Vec3> positions;
  std::vector<Face> faces;
  std::istringstream in(text);
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    SourceLocation where{file, line_number, 1};
    auto hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream fields(line);
    std::string keyword;
    if (!(fields >> keyword)) continue;
    if (keyword == "v") {
      double x, y, z;
      if (!(fields >> x >> y >> z)) throw InputError(where, "OBJ: 'v' needs three numbers");
      if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
        throw InputError(where, "OBJ: vertex is not finite");
      positions.emplace_back(x, y, z);
    } else if (keyword == "f") {
      Face f;
      f.source_line = line_number;
      std::string token;
      while (fields >> token)
        f.vertices.push_back(
            positions[parse_corner(token, static_cast<long>(positions.size()), where)]);
      if (f.vertices.size() < 3) throw InputError(where, "OBJ: a face needs at least 3 vertices");
      faces.push_back(std::move(f));
    } else if (keyword == "vn" || keyword == "vt" || keyword == "vp" || keyword == "g" ||
               keyword == "o" || keyword == "s" || keyword == "usemtl" || keyword == "mtllib") {
      // Not needed: normals come from the winding, materials from the scene file.
    } else {
      throw InputError(where, "OBJ: unsupported statement '" + keyword + "'");
    }
  }
  if (faces.empty()) throw InputError(SourceLocation{file}, "OBJ: the file has no faces");
  return faces;
}

std::vector<Face> read_obj_file(const std::string& path) {
  return read_obj_text(read_text_file(path, "the mesh file"), path);
}

}  // namespace polyrad
