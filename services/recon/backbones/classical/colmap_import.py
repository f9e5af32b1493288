"""Import pycolmap without letting it take over the process's signal handlers.

pycolmap's module initialisation installs glog's failure signal handler, which catches SIGTERM
(and SIGSEGV, SIGABRT, ...), prints a C stack and kills the process at once. A recon replica
must instead drain on SIGTERM (uvicorn's handler) and release its reconstruction leases, so the
handlers Python had before the import are put back. Only the main thread may set handlers; the
backbone is created at start-up, in the main thread, which is where this first runs.
"""

from __future__ import annotations

import logging
import signal
import threading

log = logging.getLogger("pyspatial.recon")

# The signals glog's InstallFailureSignalHandler takes.
_GLOG_SIGNALS = (signal.SIGTERM, signal.SIGSEGV, signal.SIGILL, signal.SIGFPE, signal.SIGABRT, signal.SIGBUS)

_before = {number: signal.getsignal(number) for number in _GLOG_SIGNALS}
import pycolmap  # noqa: E402  (the handlers must be read before this import)

if threading.current_thread() is threading.main_thread():
    for _number, _handler in _before.items():
        if _handler is not None:  # None: set outside Python, cannot be restored from here
            signal.signal(_number, _handler)
else:  # pragma: no cover - the service imports the backbone at start-up, in the main thread
    log.warning("pycolmap was first imported outside the main thread: SIGTERM may kill the process")

__all__ = ["pycolmap"]
