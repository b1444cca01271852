// A renumbering of T's unknowns for the locality of the series precompute (series.h,
// SeriesOptions::reorder; papers/glossy-radiosity.md, section 8).
//
// The precompute applies T to blocks of columns: each unknown's row of a block holds 3 x batch
// doubles (1.5 KiB at the default batch of 64), and T's row r reads the block rows of its
// columns. Numbered as T is built (patches, then links sorted by (from, to)), a row's columns are
// scattered over the whole block, beyond the per-core cache. Reverse Cuthill-McKee numbers the
// unknowns so that those that read each other are close, which narrows the band of T: rows
// processed one after the other then read nearly the same block rows, which are still in cache.
// On the Cornell scenes it did not pay (README, Known limits): T's diffuse rows are nearly dense
// over the patches, so the band hardly narrows, and the order T is built in already keeps a
// reflector's link rows, which read the same incoming links, together. Hence off by default.
//
//   Permutation p = reverse_cuthill_mckee(t.weights());
//   std::int64_t before = bandwidth(t.weights()), after = bandwidth(t.weights(), p);
//
// Cost: a few breadth-first searches, O(nnz) each, and one sort of each node's newly reached
// neighbours; the symmetrised pattern (2 nnz ints) and a few arrays of n ints.
#pragma once

#include <cstdint>
#include <vector>

#include "polyrad/util/sparse.h"

namespace polyrad {

// A renumbering of n unknowns: the unknown numbered `old` before is `position[old]` after, and
// `order[new]` is the unknown that gets number `new`.
struct Permutation {
  std::vector<std::int32_t> order;     // new -> old
  std::vector<std::int32_t> position;  // old -> new

  std::int64_t size() const { return static_cast<std::int64_t>(order.size()); }
  // The permutation with this `order`; throws std::invalid_argument unless every index in
  // [0, order.size()) appears exactly once.
  static Permutation from_order(std::vector<std::int32_t> order);
};

// Reverse Cuthill-McKee on the symmetrised sparsity pattern of a square matrix (entry (r, c)
// links r and c both ways; the diagonal and the values are ignored). Per connected component, a
// breadth-first search from a pseudo-peripheral node of low degree (George and Liu's search,
// started at the component's node of least degree), visiting neighbours by ascending degree;
// the whole order is reversed at the end. Ties go to the lower index: the result depends only
// on the pattern.
Permutation reverse_cuthill_mckee(const Csr<float>& m);

// max |row - column| over the stored entries of m, numbered as stored or through p (0 for a
// matrix without off-diagonal entries).
std::int64_t bandwidth(const Csr<float>& m);
std::int64_t bandwidth(const Csr<float>& m, const Permutation& p);

}  // namespace polyrad
