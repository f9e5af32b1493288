"""Child processes die with the service: the decode workers and what multiprocessing starts.

A worker of a ProcessPoolExecutor outlives its parent when the parent is killed (SIGKILL, the
OOM killer) or exits without shutting the pool down: it waits on a pipe nobody writes to any
more, and keeps the multiprocessing resource tracker alive through the descriptor it inherited
(about 96 MB each; a test run left 77 of them). Each worker therefore asks the kernel for a
signal when its parent dies (Linux's PR_SET_PDEATHSIG); the tracker then sees its pipe close
and exits by itself. This module is imported by the workers: it imports nothing heavy.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys

_PR_SET_PDEATHSIG = 1


def die_with_parent(parent_pid: int) -> None:
    """Pool initializer: this process gets SIGKILL when its parent dies (Linux; elsewhere a no-op).

    The parent may have died between fork and this call, which the signal would miss: then the
    process is already an orphan (adopted, a new parent id) and leaves at once."""
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) != 0:
            raise OSError(ctypes.get_errno(), "prctl(PR_SET_PDEATHSIG) failed")
    if os.getppid() != parent_pid:
        os._exit(0)
