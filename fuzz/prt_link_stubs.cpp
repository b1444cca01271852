// Link stand-ins for the .prt fuzz target (fuzz/CMakeLists.txt).
//
// The loader needs SeriesOperator's methods, which live in src/solve/series.cpp next to
// precompute_series. The precompute calls into the solver and the transport operator, and those
// into the specular transfer and the ray caster (Embree): far more than the loader uses. The
// fuzz targets never precompute, so the few functions the precompute calls end here instead, and
// abort if ever reached. A link error naming another polyrad function means series.cpp has
// started to call it: add a stand-in below (or the source file, if the loader itself needs it).
#include <cstdio>
#include <cstdlib>

#include "polyrad/solve/solver.h"
#include "polyrad/transport/transport.h"

namespace polyrad {

namespace {
[[noreturn]] void not_in_fuzz_build(const char* what) {
  std::fprintf(stderr, "polyrad fuzz: %s is not part of the fuzz build\n", what);
  std::abort();
}
}  // namespace

double extrapolated_decay(const std::vector<double>&) { not_in_fuzz_build("extrapolated_decay"); }
double estimate_spectral_radius(const TransportOperator&, const Field&, int) {
  not_in_fuzz_build("estimate_spectral_radius");
}
void TransportOperator::apply(const Field&, Field&) const {
  not_in_fuzz_build("TransportOperator::apply");
}
void TransportOperator::apply(const FieldBlock&, FieldBlock&) const {
  not_in_fuzz_build("TransportOperator::apply");
}
Eigen::Array3d TransportOperator::flux_norm_channels(const Field&) const {
  not_in_fuzz_build("TransportOperator::flux_norm_channels");
}
std::string TransportOperator::divergence_hint() const {
  not_in_fuzz_build("TransportOperator::divergence_hint");
}
Permutation reverse_cuthill_mckee(const Csr<float>&) { not_in_fuzz_build("reverse_cuthill_mckee"); }
std::int64_t bandwidth(const Csr<float>&) { not_in_fuzz_build("bandwidth"); }
PermutedTransport::PermutedTransport(const TransportOperator&, Permutation) {
  not_in_fuzz_build("PermutedTransport");
}
void PermutedTransport::apply(const FieldBlock&, FieldBlock&) const {
  not_in_fuzz_build("PermutedTransport::apply");
}
FieldBlock PermutedTransport::to_original(const FieldBlock&) const {
  not_in_fuzz_build("PermutedTransport::to_original");
}

}  // namespace polyrad
