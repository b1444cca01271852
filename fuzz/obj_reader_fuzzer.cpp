// libFuzzer target: bytes -> read_obj_text.
// Built by fuzz/CMakeLists.txt, run by scripts/fuzz.sh; see docs/testing.md.
#include "fuzz_entry.h"
#include "fuzz_inputs.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return polyrad::fuzz::run_one(data, size, polyrad::fuzz::obj_input);
}
