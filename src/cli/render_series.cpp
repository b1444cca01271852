// polyrad render --method series: precompute and relight in one run.
#include "render_flags.h"

namespace polyrad::cli {

int render_series(const RenderFlags&) {
  throw InputError("--method series is not available yet");
}

}  // namespace polyrad::cli
