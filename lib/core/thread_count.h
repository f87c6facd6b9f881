// The number of threads a computation's `threads` option asks for.
#pragma once

#include <tbb/info.h>

namespace meshgauge {

// `requested` when positive, else every core TBB sees (0: all cores).
inline int ThreadCount(int requested) {
  return requested > 0 ? requested : tbb::info::default_concurrency();
}

}  // namespace meshgauge
