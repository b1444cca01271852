// The .prt file: a precomputed series operator (solve/series_operator.h) on disk.
//
// Layout (little-endian):
//   magic "POLYRADQ" | u32 version | u32 header length | header (JSON: metadata and the table of
//   binary sections) | zero padding to 64 bytes | sections, each 64-byte aligned | u64 checksum
// Sections: the rows (row_start and column when sparse, values), the links and flux weights of
// solution rows, and for a solution operator behind a final gather that reads T e (mirror
// images, --indirect mesh) that light, render/mesh_direct.h (direct_*; the header's
// "mesh_direct" gives its counts). The checksum covers every byte before it. Writing goes to a
// temporary file that is renamed only when complete (util/files.h), so an interrupted precompute
// leaves nothing behind. Reading maps the file and refuses, with InputError naming the file,
// anything truncated, corrupted (checksum), foreign (magic), of another version, or inconsistent
// (sections out of bounds, indices out of range).
//
//   write_prt(q, "out/scene.prt");
//   SeriesOperator q = read_prt("out/scene.prt");      // values stay in the mapping
//   SeriesOperator r = read_prt("old.prt", {.scene = "moved/scene.json"});
//
// read_prt then checks the operator against its scene: the scene file (the one recorded, or the
// one given when it moved) must hash as it did at the precompute, and for solution rows it must
// mesh, with the recorded overrides, into the operator's patches. A stale operator is an
// InputError (exit code 2), whoever reads it.
//
// Cost: one pass over the file to write, one to verify the checksum when read, and the scene's
// parse for the check.
#pragma once

#include <string>

#include "polyrad/solve/series_operator.h"

namespace polyrad {

inline constexpr std::uint32_t kPrtVersion = 1;

struct PrtReadOptions {
  std::string scene;        // the scene file, when it moved since the precompute ("": recorded)
  bool check_scene = true;  // false: no staleness check (tools that read the file alone)
};

void write_prt(const SeriesOperator& q, const std::string& path);
SeriesOperator read_prt(const std::string& path, const PrtReadOptions& options = {});

// Reads from memory, without the staleness check (the fuzz target's entry point); `name` is
// used in error messages. data must be 8-byte aligned and outlive the result, which points
// into it.
SeriesOperator read_prt_bytes(const void* data, std::size_t size, const std::string& name);

}  // namespace polyrad
