// What the machine is and what this process uses of it, for every report and benchmark.
//
//   std::string m = machine_description();   // "AMD EPYC ..., 2 hardware threads, 23.5 GiB"
//   std::size_t peak = peak_memory_bytes();
//   std::size_t now = resident_memory_bytes();
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
// The 1, 5 and 15 minute load averages as "l1 l5 l15" ("unknown" off Linux): timings on a
// busy machine are slower and noisier, and reports say so.
std::string load_average();
// The current time in UTC, ISO 8601 ("2026-12-01T20:05:55Z").
std::string utc_now();

}  // namespace polyrad
