#pragma once
// How a Wake executable sets up its process (the library itself leaves the process as its
// host set it up).

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace wake {

/// Blocks of 1 MiB and more (the per-particle arrays) mapped on their own and given back to
/// the system when freed. glibc otherwise raises its mapping threshold to the largest block
/// freed (up to 32 MiB), and blocks below it then come from heaps whose freed memory stays
/// resident: at 2.5 million particles on two threads, 12 bytes a particle of peak resident
/// memory more. A host program with large SPH worlds may do the same
/// (`mallopt(M_MMAP_THRESHOLD, 1 << 20)`, or MALLOC_MMAP_THRESHOLD_=1048576 in its
/// environment).
inline void mapLargeBlocksApart() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 1 << 20);
#endif
}

}  // namespace wake
