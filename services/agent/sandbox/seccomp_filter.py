"""The worker's seccomp filter (child side), loaded after start-up and before the program runs.

libseccomp (Debian libseccomp2) through the `pyseccomp` ctypes bindings. An allow-list: every
syscall not named below answers EPERM (default deny), and a syscall of another ABI (32-bit
int 0x80 on x86-64) kills the process (libseccomp's bad-architecture action). ALLOWED is what the
worker was traced making after this filter loads, over the whole benign corpus
(scripts/trace_sandbox_syscalls.py; the method is in docs/ARCHITECTURE.md); MARGIN the few it
needs on paths the corpus does not reach, each with its reason; CONDITIONAL those allowed only
with safe arguments. So SysV IPC, memfd_create, userfaultfd, io_uring, bpf, perf_event_open,
keyctl, ptrace, process_vm_*, mount, unshare/setns, personality, pipes, sockets, new processes
and exec are refused because nothing put them on the list. Nothing here relies on the
Python-level checks.
"""

from __future__ import annotations

import errno
import os
import sys
import types

SONAMES = {"seccomp": "libseccomp.so.2", "c": "libc.so.6"}  # Linux with glibc, as the jail needs


def _import_bindings():  # noqa: ANN202
    """pyseccomp looks libseccomp up with ctypes.util.find_library, which imports subprocess and
    friends (~15 ms of start-up) and runs /sbin/ldconfig, absent from the jail. For that one import,
    a stand-in ctypes.util names the libraries by their sonames, which the dynamic loader finds."""
    import ctypes

    stand_in = types.ModuleType("ctypes.util")
    stand_in.find_library = SONAMES.get
    real = sys.modules.get("ctypes.util")
    sys.modules["ctypes.util"] = ctypes.util = stand_in
    try:
        import pyseccomp
    finally:
        if real is None:
            del sys.modules["ctypes.util"], ctypes.util
        else:
            sys.modules["ctypes.util"] = ctypes.util = real
    return pyseccomp


seccomp = _import_bindings()

CLONE_THREAD = 0x00010000
TCGETS = 0x5401  # the interpreter asks whether a file it opens is a terminal (isatty)
# Traced after the filter loads, over the benign corpus (scripts/trace_sandbox_syscalls.py).
ALLOWED = (
    "brk", "close", "exit", "exit_group", "futex", "getcwd", "getdents64", "getgid", "getpid", "getppid",
    "gettid", "getuid", "lseek", "madvise", "mmap", "mprotect", "munmap", "newfstatat", "read",
    "rseq", "rt_sigaction", "rt_sigprocmask", "set_robust_list", "write",
)  # fmt: skip
# Not reached by the corpus, needed all the same: glibc's realloc of a large block (mremap), the
# return from a signal handler (rt_sigreturn), faulthandler's stack on a crash (sigaltstack), clocks
# without the vDSO, a yield in futex back-off (sched_yield), hash seeds (getrandom), older glibc's fstat,
# sleeping (time.sleep in the test-only unchecked mode; the wall clock bounds it).
MARGIN = (
    "mremap", "rt_sigreturn", "sigaltstack", "clock_gettime", "gettimeofday", "sched_yield",
    "getrandom", "fstat", "clock_nanosleep", "nanosleep",
)  # fmt: skip
# Allowed only with the arguments install() checks (names listed for the trace script's check).
CONDITIONAL = ("clone", "clone3", "openat", "open", "ioctl", "tgkill", "prlimit64")
WRITE_FLAGS = os.O_WRONLY | os.O_RDWR | os.O_CREAT | os.O_TRUNC | os.O_APPEND


def _add(rules: seccomp.SyscallFilter, action: int, syscall: str, *arguments: seccomp.Arg) -> bool:
    try:
        rules.add_rule(action, syscall, *arguments)
    except (ValueError, OSError, RuntimeError):
        return False  # not a syscall of this architecture
    return True


def install() -> None:
    """Load the filter into this process (irreversible; inherited by any thread)."""
    allow = seccomp.ALLOW
    rules = seccomp.SyscallFilter(seccomp.ERRNO(errno.EPERM))
    for syscall in ALLOWED + MARGIN:
        _add(rules, allow, syscall)
    # threads only: clone with CLONE_THREAD set; clone3 answers ENOSYS so the C library falls back
    # to clone, whose flags a filter can read (clone3 passes them in memory).
    _add(rules, allow, "clone", seccomp.Arg(0, seccomp.MASKED_EQ, CLONE_THREAD, CLONE_THREAD))
    _add(rules, seccomp.ERRNO(errno.ENOSYS), "clone3")
    # files only for reading: no write, create, truncate or append flag (the jail's view is read-only).
    _add(rules, allow, "openat", seccomp.Arg(2, seccomp.MASKED_EQ, WRITE_FLAGS, 0))
    _add(rules, allow, "open", seccomp.Arg(1, seccomp.MASKED_EQ, WRITE_FLAGS, 0))
    _add(rules, allow, "ioctl", seccomp.Arg(1, seccomp.EQ, TCGETS))
    # signals only to this process itself (Python's signal.raise_signal, abort()).
    _add(rules, allow, "tgkill", seccomp.Arg(0, seccomp.EQ, os.getpid()))
    # reading a limit (argument 2, the new value, NULL); raising one is refused.
    _add(rules, allow, "prlimit64", seccomp.Arg(2, seccomp.EQ, 0))
    rules.load()
