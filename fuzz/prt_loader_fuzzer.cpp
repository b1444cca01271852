// libFuzzer target: bytes -> read_prt_bytes (as given, then with the checksum repaired) -> checks
// of the accepted operator and its product. Built by fuzz/CMakeLists.txt, run by scripts/fuzz.sh,
// which generates the seeds with `polyrad precompute`; see docs/testing.md.
#include "fuzz_entry.h"
#include "fuzz_inputs.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return polyrad::fuzz::run_one(data, size, polyrad::fuzz::prt_input);
}
