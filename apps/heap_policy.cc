// The heap policy of a rodmesh process (apps/run.hh).
#include "apps/run.hh"

#ifdef __GLIBC__
#include <malloc.h>

#include <climits>
#endif

namespace rodmesh::cli {

bool keepLargeBlocksOnHeap() {
#ifdef __GLIBC__
  // glibc serves every block above its mmap threshold (32 MiB at most) from a
  // fresh mapping and unmaps it on free. MUMPS allocates its factorization
  // workspace anew for every factorization and zeroes it, and the sparse
  // LDLT's ordering copies the Hessian's pattern: each of them then faults in
  // fresh zeroed pages from the kernel, iteration after iteration. Served
  // from the heap (no mmap) and kept there after free (trim threshold 2 GiB),
  // the pages are reused. The cost: freed memory is not given back to the
  // system (below the heap's top at all, at its top up to 2 GiB) until the
  // process exits; the peak is that of the largest working set, as before.
  // mallopt returns 1 on success.
  const bool noMmap = mallopt(M_MMAP_MAX, 0) == 1;
  const bool noTrim = mallopt(M_TRIM_THRESHOLD, INT_MAX) == 1;
  return noMmap && noTrim;
#else
  return false;
#endif
}

}  // namespace rodmesh::cli
