// What one fuzz input does, shared by the libFuzzer targets (fuzz/*_fuzzer.cpp) and by the
// GoogleTest that replays the corpus and every saved finding (tests/fuzz_regression_test.cpp).
//
// Each function feeds bytes to a stage of scene loading or to the .prt loader and lets
// exceptions escape: the caller decides what is allowed. Bad input may throw polyrad::InputError
// and nothing else; a crash, a sanitizer report or any other exception type is a finding.
//
//   polyrad::fuzz::scene_input(text);  // parse_scene_text, then resolve_scene if no mesh is used
//   polyrad::fuzz::obj_input(text);    // read_obj_text
//   polyrad::fuzz::prt_input(bytes);   // read_prt_bytes, as given and with the checksum repaired
//
// scene_input also checks what resolution promises (finite vertices, a normal per face), and
// prt_input what an accepted operator promises (consistent counts, a product that agrees with a
// plain loop); each throws std::logic_error when that does not hold.
//
// Cost: one parse of the input; resolution checks each polygon in O(n^2) of its vertices; the
// .prt loader reads its input twice, and an accepted operator's product is O(file size).
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

#include "polyrad/io/prt_file.h"
#include "polyrad/scene/scene.h"
#include "polyrad/util/half.h"
#include "polyrad/util/hash.h"

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

// What read_prt_bytes promises of an operator it accepts: counts that agree with each other and
// with the file's size, lights to name, and a product that reads only what is there. The product
// with a fixed emission is compared with a plain double-precision loop over the stored entries,
// which any float summation order meets within n 2^-23 of the sum of |terms| (n entries a row).
inline void check_operator(const SeriesOperator& q, std::size_t file_size) {
  auto fail = [](const char* why) {
    throw std::logic_error(std::string("read_prt_bytes accepted ") + why);
  };
  const std::int64_t rows = q.rows(), cols = q.cols(), nnz = q.nnz();
  if (rows < 0 || cols < 1 || nnz < 0) fail("negative counts or no columns");
  if (q.bytes() > file_size) fail("an operator larger than its file");
  if (q.dense() ? nnz != rows * cols : (q.column() == nullptr || q.start()[0] != 0))
    fail("an inconsistent layout");
  if (q.output == SeriesOutput::kView ? rows != std::int64_t{q.width} * q.height
                                      : rows != q.layout.size())
    fail("rows that match neither the image nor the unknowns");
  const UnknownLayout& l = q.layout;
  if (l.num_patches < 0 || l.link_start.size() != static_cast<std::size_t>(l.num_patches) + 1 ||
      l.link_start.back() != static_cast<std::int64_t>(l.links.size()) ||
      l.flux_weight.size() != static_cast<std::size_t>(l.size()))
    fail("an inconsistent unknown layout");
  for (const Link& link : l.links)
    if (link.from < 0 || link.to < 0 || link.from >= l.num_patches || link.to >= l.num_patches)
      fail("a link to a patch that does not exist");
  for (const SeriesColumn& c : q.columns)
    if (c.patch < -1 || c.patch >= l.num_patches) fail("a column of a patch that does not exist");
  std::vector<std::string> names = q.light_names();
  if (names.empty()) fail("an operator without lights");
  if (q.column_emission({{names.front(), Rgb(1.0, 0.5, 0.25)}}).size() !=
      static_cast<std::size_t>(3 * cols))
    fail("an emission of the wrong length");

  std::vector<float> e(3 * static_cast<std::size_t>(cols));
  for (std::size_t i = 0; i < e.size(); ++i) e[i] = 1.0f + 0.25f * static_cast<float>(i % 5);
  std::vector<float> out(3 * static_cast<std::size_t>(rows));
  q.apply(e.data(), out.data());
  auto value = [&](std::int64_t i) {
    return q.precision == ValuePrecision::kFloat
               ? static_cast<const float*>(q.values())[i]
               : half_to_float(static_cast<const std::uint16_t*>(q.values())[i]);
  };
  for (std::int64_t r = 0; r < rows; ++r) {
    const std::int64_t k0 = q.dense() ? r * cols : q.start()[r];
    const std::int64_t k1 = q.dense() ? k0 + cols : q.start()[r + 1];
    for (int ch = 0; ch < 3; ++ch) {
      double sum = 0.0, magnitude = 0.0;
      for (std::int64_t k = k0; k < k1; ++k) {
        const std::int64_t c = q.dense() ? k - k0 : q.column()[k];
        const double term = static_cast<double>(value(3 * k + ch)) * e[3 * c + ch];
        sum += term;
        magnitude += std::abs(term);
      }
      // Non-finite or huge stored values make any order of summation legitimate.
      if (!std::isfinite(magnitude) || magnitude > 1e37) continue;
      const double got = out[3 * r + ch];
      if (!(std::abs(got - sum) <= static_cast<double>(k1 - k0 + 1) * 0x1p-23 * magnitude + 1e-37))
        fail("an operator whose product disagrees with its entries");
    }
  }
}

// A copy of the input at a 64-byte boundary (read_prt_bytes needs 8), of exactly its size so
// that the sanitizers see any read past the end.
struct AlignedBytes {
  explicit AlignedBytes(const std::string& bytes)
      : size(bytes.size()),
        data(static_cast<unsigned char*>(::operator new (size, std::align_val_t{64}))) {
    if (size) std::memcpy(data, bytes.data(), size);
  }
  ~AlignedBytes() { ::operator delete (data, std::align_val_t{64}); }
  AlignedBytes(const AlignedBytes&) = delete;
  AlignedBytes& operator=(const AlignedBytes&) = delete;
  std::size_t size;
  unsigned char* data;
};

// The .prt loader. A mutated file almost never keeps its checksum, which the loader verifies
// before it reads the header; so an input whose checksum is wrong must be refused, and then goes
// through the loader again with the checksum repaired, to reach the header and the sections.
inline void prt_input(const std::string& bytes) {
  AlignedBytes file(bytes);
  if (file.size >= 24) {
    const std::uint64_t sum = checksum64(file.data, file.size - 8);
    if (std::memcmp(file.data + file.size - 8, &sum, 8) != 0) {
      try {
        SeriesOperator q = read_prt_bytes(file.data, file.size, "fuzz.prt");
        throw std::logic_error("read_prt_bytes accepted a file whose checksum is wrong");
      } catch (const InputError&) {
      }
      std::memcpy(file.data + file.size - 8, &sum, 8);
    }
  }
  SeriesOperator q = read_prt_bytes(file.data, file.size, "fuzz.prt");
  check_operator(q, file.size);
}

}  // namespace polyrad::fuzz
