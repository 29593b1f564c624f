#!/usr/bin/python3
"""The heap policy from Python: one default optimize run, timed with rusage.

    PYTHONPATH=build/python /usr/bin/python3 benchmarks/defaults/python_heap_policy.py default|policy SCENE

`policy` calls rodmesh.keep_large_blocks_on_heap() first. Prints wall, user
and system time, minor page faults, peak RSS, status, RMS and the history's
length (rows of benchmarks/defaults/results_2026-12-02_s28.md).
"""
import resource, sys, time
import rodmesh
applied = rodmesh.keep_large_blocks_on_heap() if sys.argv[1] == "policy" else None
t = time.time()
r = rodmesh.optimize(sys.argv[2])
wall = time.time() - t
u = resource.getrusage(resource.RUSAGE_SELF)
print("%s applied=%s wall %.1f s user %.1f s sys %.2f s minflt %d maxrss %.0f MB status %s RMS %.6f mm iterations %d" % (
    sys.argv[1], applied, wall, u.ru_utime, u.ru_stime, u.ru_minflt, u.ru_maxrss / 1024, r.status, 1e3 * r.rms_error,
    len(r.history["iteration"])))
