// T's stored rows with the unknowns renumbered (transport/reorder.h), for the series
// precompute's block products (SeriesOptions::reorder): row n is T's row p.order[n], its columns
// mapped through p.position. Each row keeps its entries in T's order, so a product sums the same
// terms in the same order as T's does and gives the same bits, permuted; the columns of a row are
// then not ascending, so Csr::at does not apply to weights(). Memory: a second copy of T's weights.
// An operator whose link rows are recomputed on the fly stores none to permute: the
// constructor refuses it (InputError).
//
//   PermutedTransport pt(t, reverse_cuthill_mckee(t.weights()));
//   pt.apply(x, y);                          // y = P T P^T x, x and y in the new numbering
//   FieldBlock u = pt.to_original(y);        // u.row(p.order[n]) = y.row(n)
//
// Cost: building copies T's stored weights once; apply() is T's product.
#pragma once

#include "polyrad/transport/reorder.h"
#include "polyrad/transport/transport.h"

namespace polyrad {

class PermutedTransport {
 public:
  PermutedTransport(const TransportOperator& t, Permutation p);
  Eigen::Index size() const { return static_cast<Eigen::Index>(weights_.rows); }
  const Permutation& permutation() const { return permutation_; }
  const Csr<float>& weights() const { return weights_; }
  // out = (P T P^T) in; in and out must not alias.
  void apply(const FieldBlock& in, FieldBlock& out) const;
  // A block in this numbering, renumbered as T's unknowns.
  FieldBlock to_original(const FieldBlock& x) const;

 private:
  Permutation permutation_;
  Csr<float> weights_;
  std::vector<Eigen::Array3f> row_colour_;
};

}  // namespace polyrad
