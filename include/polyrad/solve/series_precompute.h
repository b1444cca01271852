// The precompute of the truncated power series of the transport operator (papers/glossy-
// radiosity.md, section 6): K applications of T to the columns of S, restricted to the rows
// the caller wants.
//
//   Q = E S + G P_K S,   P_K = sum_{n=0..K} T^n
//
// S: one column per emitting patch (unit emission), grouped by the emitting object's name.
// Rows: `view`, the pixels of the world's camera through the gather G (built here from
// options.gather); or `solution`, every unknown (any camera afterwards needs only the gather,
// which relighting builds from the options recorded in the operator). K is given, or the
// smallest that meets the tolerance by the a-priori bound or the a-posteriori estimate.
//
//   SeriesOptions o;
//   o.tolerance = 1e-3;
//   SeriesOperator q = precompute_series(sys->transport, *sys->world, o);
//
// Cost: K sparse products over columns-wide blocks (O(K nnz(T) C) time; 3 blocks of unknowns x
// 3C doubles per column batch), plus the gather's build in view mode.
#pragma once

#include <vector>

#include "polyrad/render/camera_gather.h"
#include "polyrad/solve/series_operator.h"
#include "polyrad/transport/transport.h"
#include "polyrad/world/world.h"

namespace polyrad {

struct SeriesOptions {
  int order = -1;           // K; -1: the smallest K that meets `tolerance`
  double tolerance = 1e-3;  // relative error of the solution, flux-weighted 1-norm
  int max_order = 100000;
  double drop = 0.0;  // drop each column's smallest entries, up to this share of its energy
  ValuePrecision precision = ValuePrecision::kFloat;
  SeriesOutput output = SeriesOutput::kView;
  // One column per emitting patch (the default), or one per emitting object (its patches
  // together, as they always share the object's emission): far fewer columns, same answer
  // for any relighting that sets whole objects.
  SeriesBasis basis = SeriesBasis::kPatch;
  // Columns computed together: at most column_batch, and fewer where the batch's three blocks
  // of unknowns (the term, the next, the sum) and the sum's float copy (84 bytes an unknown a
  // column) would pass batch_bytes; the columns are then shared evenly between the batches
  // (series_batch).
  int column_batch = 64;
  double batch_bytes = 1024.0 * 1024.0 * 1024.0;
  bool progress = true;  // a Progress display (when displays are enabled at all)
  SeriesAcceleration acceleration = SeriesAcceleration::kNone;
  // Chebyshev: the spectral radius rho; 0 estimates it from power steps (capped by a_max).
  double chebyshev_radius = 0.0;
  // kRcm: the K block products run on a copy of T renumbered by reverse Cuthill-McKee (S is
  // permuted in, each block's result back out before the rows are formed), for cache locality;
  // each row sums in T's order, so Q is the same bits. Not with on-the-fly link rows.
  SeriesReorder reorder = SeriesReorder::kNone;
  // The gather folded into view rows, or recorded for relighting solution rows.
  GatherOptions gather;
};

// The columns of S for a set of patches.
// The columns of S over the world's patches: one per emitting patch, or per emitting object.
// (With a hierarchical mesh a patch's column lights every leaf under it.)
std::vector<SeriesColumn> series_columns(const PatchSet& patches, const Scene& scene,
                                         SeriesBasis basis);

// The columns each batch computes together (the last batch may have fewer), for `unknowns`
// unknowns and `columns` columns in all. The room's hierarchy (570,000 unknowns, 135 columns):
// 7 batches of 20 instead of 3 of 64, 0.89 GiB of blocks instead of 2.6.
int series_batch(const SeriesOptions& options, double unknowns, double columns);

// The bytes the precompute's rows hold at their peak (for the memory estimate,
// transport/memory_estimate.h): a batch's three blocks of unknowns (the term, the next, the
// sum) and the sum's float copy; view rows keep every batch's P_K S (unknowns x 3 floats a column)
// and their pixel rows (3 doubles a column) beside the kept entries (16 bytes): 40 bytes per pixel
// and column, as measured on cornell-box at 512^2 and 1024^2.
double rows_memory(const SeriesOptions& options, double rows, double unknowns, double columns);
// The same before meshing, with the deferred gather of view rows: rows are the camera's pixels
// (view) or the patches (solution), unknowns and columns are counted from `scene` (with the
// overrides applied, as World::scene() is).
double rows_memory(const SeriesOptions& options, const Scene& scene);

// Runs the precompute. View rows, Q = E S + G P_K S (eq. 12), fold in `gather` when given (it
// must have been built from options.gather for this world and T), else a gather of the world's
// camera whose rows are built here block by block (defer_gather), so that a final gather is
// never held whole. Throws NumericalError if the
// term norms grow (the series diverges), InputError if the world has no light.
SeriesOperator precompute_series(const TransportOperator& t, const World& world,
                                 const SeriesOptions& options, const Gather* gather = nullptr);

}  // namespace polyrad
