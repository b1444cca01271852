// T renumbered for the precompute's locality (transport/permuted_transport.h).
#include "polyrad/transport/permuted_transport.h"

#include "polyrad/util/error.h"

namespace polyrad {

PermutedTransport::PermutedTransport(const TransportOperator& t, Permutation p)
    : permutation_(std::move(p)) {
  if (t.on_the_fly())
    throw InputError(
        "reordering needs T's stored rows; with --specular-on-the-fly its link rows "
        "are recomputed at every product (use --reorder none)");
  if (t.hierarchical())
    throw InputError(
        "reordering needs T's stored rows; a hierarchical mesh keeps T factored "
        "in its trees and links (use --reorder none)");
  const Csr<float>& w = t.weights();
  POLYRAD_CHECK(permutation_.size() == w.rows);
  weights_.rows = 0;
  weights_.cols = w.cols;
  weights_.column.reserve(w.column.size());
  weights_.value.reserve(w.value.size());
  for (std::int32_t old : permutation_.order) {
    for (auto [column, value] : w.row(old)) {
      weights_.column.push_back(permutation_.position[column]);
      weights_.value.push_back(value);
    }
    weights_.push_row();
    row_colour_.push_back(t.row_colour()[old]);
  }
}

void PermutedTransport::apply(const FieldBlock& in, FieldBlock& out) const {
  apply_weighted_rows(weights_, row_colour_, in, out);
}

FieldBlock PermutedTransport::to_original(const FieldBlock& x) const {
  FieldBlock u(x.rows(), x.cols());
#pragma omp parallel for schedule(static)
  for (Eigen::Index n = 0; n < x.rows(); ++n) u.row(permutation_.order[n]) = x.row(n);
  return u;
}

}  // namespace polyrad
