// What the machine is and what this process uses of it, for every report and benchmark.
//
//   std::string m = machine_description();   // "AMD EPYC ..., 2 hardware threads, 23.5 GiB"
//   std::size_t peak = peak_memory_bytes();
//   std::size_t now = resident_memory_bytes();
//   return_large_blocks_to_the_system();     // first thing in main()
//   resize_on_huge_pages(rows.value, entries);  // a large array, before it is filled
//
// Cost: a read of /proc (cpuinfo, loadavg) or one getrusage call.
#pragma once

#include <cstddef>
#include <string>

namespace polyrad {

// CPU model, hardware threads and physical memory, on one line.
std::string machine_description();
// The CPU model alone ("unknown CPU" when /proc/cpuinfo does not say).
std::string cpu_model();
double physical_memory_bytes();
// Peak resident memory of this process so far.
std::size_t peak_memory_bytes();
// Resident memory of this process now (its peak so far where /proc does not say): what it
// holds, and what its allocator keeps of what it freed.
std::size_t resident_memory_bytes();
// Has the allocator give every block of 256 KiB or more back to the system when it is freed
// (glibc's allocator; elsewhere this does nothing). Call once, first thing in a program. By
// default glibc raises that threshold to the largest block freed so far, so once a build's
// transient arrays are freed, later ones of that size come from the heap and their pages stay
// resident after they too are freed: 25 MB of the peak of the mirror cube's hierarchical render.
void return_large_blocks_to_the_system();
// Asks the system to back [data, data + bytes) with huge pages where it can (Linux's
// transparent huge pages, madvise mode; elsewhere, or for less than 2 MiB, nothing). For the
// large arrays a build fills once it has allocated them: each 4 KiB page's first touch is a
// fault, and on a virtual machine a fault cost about 10 us (the room's hierarchical render took
// 670 thousand). Call it before the first write: resize_on_huge_pages does both. The polyrad
// program's operator new calls it for every block of 2 MiB or more (src/cli/allocation.cpp).
void advise_huge_pages(const void* data, std::size_t bytes);
template <typename Vector>
void resize_on_huge_pages(Vector& v, std::size_t size) {
  v.reserve(size);
  advise_huge_pages(v.data(), v.capacity() * sizeof(v[0]));
  v.resize(size);
}
// The 1, 5 and 15 minute load averages as "l1 l5 l15" ("unknown" off Linux): timings on a
// busy machine are slower and noisier, and reports say so.
std::string load_average();
// The current time in UTC, ISO 8601 ("2026-12-01T20:05:55Z").
std::string utc_now();

}  // namespace polyrad
