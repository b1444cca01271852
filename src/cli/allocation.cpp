// The polyrad program's operator new: a block of 2 MiB or more is asked for transparent huge
// pages before anything touches it (util/machine.h, advise_huge_pages).
//
// main() has glibc map every block of 256 KiB or more on its own and unmap it when freed
// (return_large_blocks_to_the_system), which keeps the peak down, but each such block is faulted
// in 4 KiB at a time, and a fault costs about 10 us on a virtual machine: the room's hierarchical
// render took 462,000 of them, most in the builder's growing element array and its transient
// link buffers. Asked for huge pages, a block faults 2 MiB at a time.
//
// Only the program does this (the library leaves allocation to whoever links it), and not
// under a sanitizer, whose runtime has its own operator new (AddressSanitizer checks that new
// and delete are paired; ThreadSanitizer's would collide with these at link time).
// Cost: one madvise call per block of 2 MiB or more; blocks stay glibc's (malloc and free).
#include <cerrno>
#include <cstdlib>
#include <new>

#include "polyrad/util/machine.h"

// CMake leaves this file out of sanitized builds (POLYRAD_SANITIZE); the guard is for others.
#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || \
    __has_feature(memory_sanitizer) || __has_feature(leak_sanitizer)
#define POLYRAD_SANITIZED_ALLOCATION 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define POLYRAD_SANITIZED_ALLOCATION 1
#endif

#if !defined(POLYRAD_SANITIZED_ALLOCATION)

namespace {

constexpr std::size_t kHugeBlock = std::size_t{1} << 21;

void* allocate(std::size_t size) {
  if (size == 0) size = 1;
  void* p = nullptr;
  while (!(p = std::malloc(size))) {  // as the standard operator new: the handler, then throw
    const std::new_handler handler = std::get_new_handler();
    if (!handler) throw std::bad_alloc();
    handler();
  }
  if (size >= kHugeBlock) {
    const int saved = errno;  // madvise fails with EINVAL where there are no huge pages
    polyrad::advise_huge_pages(p, size);
    errno = saved;
  }
  return p;
}

}  // namespace

// The standard's nothrow forms call these; libstdc++'s aligned forms use aligned_alloc and free:
// every delete frees what its new allocated, by malloc's family.
void* operator new(std::size_t size) { return allocate(size); }
void* operator new[](std::size_t size) { return allocate(size); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }

#endif
