"""The worker's seccomp filter (child side), loaded after start-up and before the program runs.

libseccomp (Debian libseccomp2) through the `pyseccomp` ctypes bindings. Default allow, and refuse
with EPERM what a program never needs: new processes (threads may stay), exec, signals to other
processes, sockets, tracing, namespaces and mounts, new sessions, opening files for writing or
creating them, changing the file system, raising resource limits, io_uring (which would bypass
this filter) and kernel-level odds and ends. Nothing here relies on the Python-level checks.
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
# Syscalls refused outright. Names missing on an architecture (e.g. `fork` on arm64) are skipped.
REFUSED = (
    # processes and programs
    "fork", "vfork", "execve", "execveat", "setsid", "setpgid", "ptrace", "process_vm_readv",
    "process_vm_writev", "kill", "tkill", "rt_sigqueueinfo", "rt_tgsigqueueinfo", "pidfd_open",
    "pidfd_send_signal", "pidfd_getfd",
    # network
    "socket", "socketpair", "connect", "bind", "listen", "accept", "accept4",
    # namespaces, mounts, identities
    "unshare", "setns", "mount", "umount2", "pivot_root", "chroot", "move_mount", "open_tree",
    "fsopen", "fsmount", "fspick", "setuid", "setgid", "setreuid", "setregid", "setresuid",
    "setresgid", "setgroups", "capset",
    # files: creating, changing, writing
    "creat", "openat2", "open_by_handle_at", "name_to_handle_at", "unlink", "unlinkat", "rename",
    "renameat", "renameat2", "mkdir", "mkdirat", "rmdir", "link", "linkat", "symlink", "symlinkat",
    "chmod", "fchmod", "fchmodat", "chown", "fchown", "lchown", "fchownat", "truncate", "mknod",
    "mknodat", "setxattr", "lsetxattr", "fsetxattr",
    # limits and kernel facilities
    "setrlimit", "io_uring_setup", "io_uring_enter", "io_uring_register", "bpf", "perf_event_open",
    "userfaultfd", "keyctl", "add_key", "request_key", "kexec_load", "kexec_file_load",
    "init_module", "finit_module", "delete_module", "reboot", "swapon", "swapoff", "syslog", "acct",
    "quotactl", "mount_setattr", "fanotify_init", "inotify_init", "inotify_init1",
)  # fmt: skip
# clone3 answers ENOSYS so the C library falls back to clone, whose flags a filter can read.
ENOSYS_SYSCALLS = ("clone3",)
WRITE_FLAGS = (os.O_WRONLY, os.O_RDWR, os.O_CREAT, os.O_TRUNC, os.O_APPEND)


def _add(rules: seccomp.SyscallFilter, action: int, syscall: str, *arguments: seccomp.Arg) -> bool:
    try:
        rules.add_rule(action, syscall, *arguments)
    except (ValueError, OSError, RuntimeError):
        return False  # not a syscall of this architecture
    return True


def install() -> None:
    """Load the filter into this process (irreversible; inherited by any thread)."""
    refuse = seccomp.ERRNO(errno.EPERM)
    rules = seccomp.SyscallFilter(seccomp.ALLOW)
    for syscall in REFUSED:
        _add(rules, refuse, syscall)
    for syscall in ENOSYS_SYSCALLS:
        _add(rules, seccomp.ERRNO(errno.ENOSYS), syscall)
    # clone only for threads: refuse when CLONE_THREAD is absent from the flags (argument 0).
    _add(rules, refuse, "clone", seccomp.Arg(0, seccomp.MASKED_EQ, CLONE_THREAD, 0))
    # signals only to this process itself (Python's signal.raise_signal, abort()).
    _add(rules, refuse, "tgkill", seccomp.Arg(0, seccomp.NE, os.getpid()))
    # raising a limit: prlimit64 with a new value (argument 2 not NULL); reading stays allowed.
    _add(rules, refuse, "prlimit64", seccomp.Arg(2, seccomp.NE, 0))
    # files only for reading: refuse any write, create, truncate or append flag.
    for flag in WRITE_FLAGS:
        _add(rules, refuse, "open", seccomp.Arg(1, seccomp.MASKED_EQ, flag, flag))
        _add(rules, refuse, "openat", seccomp.Arg(2, seccomp.MASKED_EQ, flag, flag))
    rules.load()
