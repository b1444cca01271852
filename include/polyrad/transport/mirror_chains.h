// The chains of mirror planes a straight path from a point x may pass, each plane after the first
// one that faces the one before and with no light on it (MirrorPlanes::Plane::emits; a diffuse
// part is no bar): the final gather draws the lamps at their images through each
// (render/final_gather.cpp) and follows its samples on through the same chains. Unfolded, a path x
// -> p_0 -> ... -> p_{n-1} through planes q_0 ... q_{n-1} is the straight line from x through the
// windows
//     W_0,  R_0(W_1),  R_0 R_1(W_2),  ...,  R_0 ... R_{n-2}(W_{n-1})      (R_t: the reflection
//                                                                          in plane q_t)
// so a chain can carry light only if one line from x passes them all. Seen from x, each unfolded
// window beyond plane q_0 is projected onto q_0's plane (centrally, from x); the chain's beam is
// the intersection of those projections with W_0, and a chain whose beam is empty is not kept,
// nor any chain it begins (nor one no wider than ten times the windows' growth against rounding,
// 1e-5 of the scene's diameter, measured in the first plane: a sliver where two walls meet; a
// point nearer the first plane than about that sees its real beams that thin too, and leaves
// their light to the links). Among three or more planes that face each other (a room's four mirror
// walls) the chains grow as the square of their length or faster, so they are kept level by
// level (all of length n, then all of n + 1) while their count stays within a budget.
//
//   MirrorChains chains = mirror_chains(planes, x, 16, 256);
//   std::int32_t at = chains.next(-1, q0);   // the chain of one plane, q0
//   at = chains.next(at, q1);                // -1 if q0 q1 is not a chain kept
//
// Cost: per chain kept or tried, its window's corners unfolded, projected and clipped against
// the beam (hundreds of operations); no rays. The final gather builds them at every hit: a few
// percent of its time between two facing mirrors; on a room of four mirror walls at a budget of
// 1024, 42 percent, more than its rays (perf).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "polyrad/transport/mirror_planes.h"

namespace polyrad {

struct MirrorChains {
  struct Chain {
    std::int32_t plane;   // its last plane
    std::int32_t parent;  // the chain one plane shorter, -1 for a chain of one
    int length;
    std::int32_t first_child = 0, children = 0;  // the chains one plane longer, contiguous
    std::int32_t beam_begin = 0, beam_size = 0;  // its beam's corners in `beams`
  };
  Vec3 x;                     // the point the chains start from
  std::vector<Chain> chains;  // by length: the chains of one plane first
  std::vector<Vec2> beams;    // each chain's beam, in its first plane's coordinates
  int roots = 0;              // the chains of one plane
  int depth = 0;              // the longest length kept (every chain up to it kept)
  bool cut = false;           // whether the budget left out the next length's chains

  // The chain `at` continued into plane q (at = -1: the chain of plane q alone), or -1.
  std::int32_t next(std::int32_t at, std::int32_t q) const;
  // The planes of chain `at`, first to last, in out[0, length).
  void planes_of(std::int32_t at, std::int32_t* out) const;
  // Whether the line from x through the point c (coordinates in the chain's first plane) lies in
  // chain `at`'s beam.
  bool in_beam(std::int32_t at, const Vec2& c) const;
};

// The chains from x of up to max_length planes, whole levels while at most `budget` chains of
// two or more planes are kept. None if max_length < 2 or no plane faces another.
MirrorChains mirror_chains(const MirrorPlanes& m, const Vec3& x, int max_length,
                           std::size_t budget);

}  // namespace polyrad
