// CPU seconds (user + system) of this process so far, for benchmarks that
// print CPU beside wall time (on a shared machine the steadier figure).
#pragma once

#include <sys/resource.h>

namespace scanbench {

inline double ProcessCpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  auto seconds = [](const timeval& t) { return t.tv_sec + t.tv_usec * 1e-6; };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

}  // namespace scanbench
