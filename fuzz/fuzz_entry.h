// The libFuzzer side of a target: runs one input and turns every outcome other than success or
// polyrad::InputError into a crash that libFuzzer records (it then saves the input).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "polyrad/util/error.h"

namespace polyrad::fuzz {

template <typename Run>
int run_one(const std::uint8_t* data, std::size_t size, Run run) {
  std::string text(reinterpret_cast<const char*>(data), size);
  try {
    run(text);
  } catch (const InputError&) {
    // Bad input reported the documented way.
  } catch (const std::exception& e) {
    std::fprintf(stderr, "polyrad fuzz: exception other than InputError escaped: %s\n", e.what());
    std::abort();
  } catch (...) {
    std::fprintf(stderr, "polyrad fuzz: non-standard exception escaped\n");
    std::abort();
  }
  return 0;
}

}  // namespace polyrad::fuzz
