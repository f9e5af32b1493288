"""A reconstruction leaves numpy's BLAS on one thread for the process, in every thread."""

from __future__ import annotations

import threading

from threadpoolctl import threadpool_info

from services.recon.backbones.classical import ClassicalBackbone
from services.recon.backbones.classical.blas_threads import use_one_blas_thread
from tests.support.scenes import orbit_views


def _blas_threads() -> list[int]:
    return [pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"]


def test_after_a_reconstruction_blas_runs_on_one_thread_in_every_thread():
    views = orbit_views(seed=5, num_views=3, width=320, height=240)
    views_intrinsics = list(views.intrinsics)
    ClassicalBackbone().reconstruct(views.images, intrinsics=views_intrinsics)
    assert _blas_threads() and all(count == 1 for count in _blas_threads())
    seen: list[list[int]] = []
    worker = threading.Thread(target=lambda: seen.append(_blas_threads()))
    worker.start()
    worker.join(10)
    assert seen and all(count == 1 for count in seen[0])
    use_one_blas_thread()  # again: nothing changes
    assert all(count == 1 for count in _blas_threads())
