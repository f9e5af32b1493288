"""numpy's (and OpenCV's) BLAS on one thread in a process that runs the classical backbone.

The backbone parallelizes itself: one thread per image for detection and one per pair for
matching and the two-view fits. BLAS's own threads would fight those for the same cores
(templeRing's six pairs: 0.29 s matched with OpenBLAS's two threads, 0.24 s with one; the same
matches). So the first reconstruction sets BLAS to one thread for the process, once, and leaves
it so. A limit set and restored around each matching was tried first: threadpoolctl's limit is
process-wide, so two reconstructions overlapping in the service's worker threads restore it out of
order; even counted (the last one out restores), 40 of 40 interleaved runs here ended with BLAS
on one thread (the cause was not found). torch's own thread pool (VGGT, Pi3) is not a BLAS that
threadpoolctl limits, so the learned backbones keep their threads.
"""

from __future__ import annotations

import threading

from threadpoolctl import threadpool_limits

_lock = threading.Lock()
_done = False


def use_one_blas_thread() -> None:
    """Set every loaded BLAS to one thread, the first time only (later calls do nothing)."""
    global _done
    with _lock:
        if not _done:
            threadpool_limits(limits=1, user_api="blas")
            _done = True
