# Warnings live on an INTERFACE target so that every polyrad target opts in alike,
# and a project that consumes polyrad does not inherit them.
add_library(polyrad_warnings INTERFACE)
target_compile_options(polyrad_warnings INTERFACE
  $<$<CXX_COMPILER_ID:GNU,Clang>:-Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
   -Wno-unknown-pragmas>
  # GCC 12 reports -Wrestrict inside std::string concatenation (GCC bug 105329).
  $<$<CXX_COMPILER_ID:GNU>:-Wno-restrict>)

if(POLYRAD_SANITIZE)
  # -g1: line tables, all a sanitizer's stack trace reads; full -g made the build a third slower.
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer
                      -fno-sanitize-recover=undefined -g1)
  add_link_options(-fsanitize=address,undefined)
  # Clang cannot vectorise some `omp simd` loops once they are instrumented; it says so on every
  # such loop, which is the instrumentation's doing, not the code's.
  if(CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    add_compile_options(-Wno-pass-failed)
  endif()
endif()
