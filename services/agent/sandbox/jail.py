"""The OS-level jail around the sandbox worker: the wall that holds when the Python-level ones fail.

The worker runs under bubblewrap (Debian `bubblewrap`, a small, widely used namespace launcher):
- own PID, network (empty: no interfaces but a downed loopback), IPC, UTS and mount namespaces;
- a read-only view of only the interpreter, the site-packages directory, the sandbox's own code
  (`services/agent/sandbox`, `shared`), `/usr/lib*`; a private tmpfs at /tmp; no /etc, no /home, no
  repository beyond that;
- an unprivileged uid/gid (65534, "nobody") with every capability dropped (bounding set too, so
  CAP_SYS_RESOURCE cannot raise rlimits back) and PR_SET_NO_NEW_PRIVS. As root (CI) bubblewrap
  creates the namespaces itself and `setpriv` switches to the real host uid 65534 inside; as a
  non-root service user it uses an unprivileged user namespace and keeps that user's uid;
- `--die-with-parent`: PR_SET_PDEATHSIG(SIGKILL), so a killed agent leaves no sandbox behind;
- the worker then loads a seccomp filter (seccomp_filter.py) before the program's first line.

Where bubblewrap is missing or cannot create namespaces (a container without the rights, not
Linux), `probe()` says why; the service logs it loudly, reports it in /readyz and refuses to run
model-written programs unless the operator sets PYSPATIAL_SANDBOX_JAIL=off.
"""

from __future__ import annotations

import enum
import functools
import logging
import os
import shutil
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from services.agent.sandbox.protocol import ProtocolError
from services.agent.sandbox.text import clean_text
from services.agent.sandbox.worker_process import (
    JAILED_BOOT,
    REPO_ROOT,
    SandboxLimits,
    ToolFailure,
    child_environment,
    job_message,
    run_worker,
)

log = logging.getLogger("pyspatial.sandbox")

SANDBOX_UID = 65534  # "nobody": owns nothing on the host
SANDBOX_GID = 65534
WORKDIR_PREFIX = "pyspatial-sandbox-"
# Directories of the repository the worker imports from (everything else stays invisible).
_CODE_DIRS = ("services/agent/sandbox", "shared")
_CODE_FILES = ("services/__init__.py", "services/agent/__init__.py")
_LIBRARY_DIRS = ("/usr/lib", "/usr/lib64", "/usr/lib32")
_TOP_LEVEL_LINKS = ("/lib", "/lib64", "/lib32")
_THIRD_PARTY_MODULES = ("numpy", "PIL", "pyseccomp")


class JailMode(enum.StrEnum):
    REQUIRED = "required"  # run programs only inside the jail (the default)
    OFF = "off"  # operator opt-out: Python-level checks and rlimits only


@dataclass(frozen=True)
class JailStatus:
    """What /readyz and the start-up log say about the OS jail."""

    mode: JailMode
    available: bool
    detail: str

    @property
    def jailed(self) -> bool:
        """Programs run inside the OS jail."""
        return self.mode is JailMode.REQUIRED and self.available

    @property
    def runs_programs(self) -> bool:
        return self.jailed or self.mode is JailMode.OFF

    def summary(self) -> dict[str, object]:
        if self.jailed:
            state = "active"
        else:
            state = "off (operator opt-out)" if self.mode is JailMode.OFF else "unavailable"
        return {
            "jail": state,
            "runs_programs": self.runs_programs,
            "detail": self.detail,
        }


def _site_packages() -> list[str]:
    """The resolved directories holding the third-party modules the worker imports."""
    import importlib.util

    found: list[str] = []
    for name in _THIRD_PARTY_MODULES:
        spec = importlib.util.find_spec(name)
        if spec is None or spec.origin is None:
            continue
        origin = Path(spec.origin).resolve()
        directory = origin.parents[1] if origin.name == "__init__.py" else origin.parent
        if str(directory) not in found:
            found.append(str(directory))
    return found


@functools.cache
def interpreter() -> str:
    """The real interpreter binary (a virtual environment's python is a symlink to it)."""
    return os.path.realpath(sys.executable)


@functools.cache
def python_path() -> tuple[str, ...]:
    """sys.path entries the jailed worker needs: the repository, then site-packages."""
    return (str(REPO_ROOT), *_site_packages())


def _read_only_binds() -> list[str]:
    binds: list[str] = []
    for directory in _LIBRARY_DIRS:
        if os.path.isdir(directory):
            binds.append(directory)
    prefix = os.path.realpath(sys.base_prefix)
    binds += [prefix, *python_path()[1:]]
    binds += [str(REPO_ROOT / relative) for relative in _CODE_DIRS + _CODE_FILES]
    # Parent directories bubblewrap would create as 0700 (unreadable once we are uid 65534).
    parents = sorted({str(parent) for bind in binds for parent in Path(bind).parents if str(parent) != "/"})
    arguments: list[str] = []
    for parent in parents:
        arguments += ["--perms", "0755", "--dir", parent]
    for bind in binds:
        arguments += ["--ro-bind", bind, bind]
    for link in _TOP_LEVEL_LINKS:
        if os.path.islink(link):
            arguments += ["--symlink", os.readlink(link), link]
        elif os.path.isdir(link):
            arguments += ["--ro-bind", link, link]
    return arguments


def bwrap_command(worker_arguments: list[str]) -> list[str]:
    """The command line that starts `python worker_arguments...` inside the jail."""
    bwrap = shutil.which("bwrap")
    if bwrap is None:
        raise FileNotFoundError("bubblewrap (bwrap) is not installed")
    command = [
        bwrap,
        "--unshare-pid", "--unshare-net", "--unshare-ipc", "--unshare-uts", "--unshare-cgroup-try",
        "--die-with-parent", "--new-session",
        # The private /tmp first: binds that follow may lie under /tmp (a checkout or a virtual
        # environment there) and must be mounted on top of it, not hidden by it.
        "--proc", "/proc", "--dev", "/dev", "--tmpfs", "/tmp",
        *_read_only_binds(),
        "--chdir", "/tmp",
    ]  # fmt: skip
    if os.geteuid() == 0:
        # Privileged bubblewrap keeps only these two capabilities, which setpriv uses to become the
        # unprivileged host user and then drops with everything else (inheritable and bounding sets).
        setpriv = shutil.which("setpriv") or "/usr/bin/setpriv"
        command += ["--cap-add", "CAP_SETUID", "--cap-add", "CAP_SETGID"]
        command += ["--ro-bind", setpriv, setpriv, "--", setpriv]
        command += [f"--reuid={SANDBOX_UID}", f"--regid={SANDBOX_GID}", "--clear-groups"]
        command += ["--inh-caps=-all", "--bounding-set=-all", "--"]
    else:
        # Unprivileged: bubblewrap makes a user namespace, maps our uid and drops every capability.
        command[1:1] = ["--unshare-user", "--disable-userns"]
        command += ["--"]
    return command + [interpreter(), *worker_arguments]


def jailed_worker_command() -> list[str]:
    """The sandbox worker inside the jail: `python -I -S` with exactly the mounted sys.path."""
    return bwrap_command(["-I", "-S", "-c", JAILED_BOOT.format(paths=list(python_path()))])


def workdir_prefix() -> str:
    """Host work directories (opt-out mode only) carry the owning process id: pyspatial-sandbox-PID-."""
    return f"{WORKDIR_PREFIX}{os.getpid()}-"


def _owner_alive(name: str) -> bool:
    owner = name.removeprefix(WORKDIR_PREFIX).split("-", 1)[0]
    if not owner.isdigit():
        return False
    try:
        os.kill(int(owner), 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def remove_stale_workdirs(root: str | None = None) -> int:
    """Delete `pyspatial-sandbox-*` directories whose agent process is gone; returns how many.

    The jail itself leaves nothing on the host (its /tmp is a private tmpfs); these come from the
    opt-out mode or from versions before the jail.
    """
    root = root or tempfile.gettempdir()
    removed = 0
    try:
        entries = list(os.scandir(root))
    except OSError:
        return 0
    for entry in entries:
        if not entry.name.startswith(WORKDIR_PREFIX) or not entry.is_dir(follow_symlinks=False):
            continue
        if not _owner_alive(entry.name):
            shutil.rmtree(entry.path, ignore_errors=True)
            removed += 1
    return removed


@functools.cache
def probe(mode: JailMode = JailMode.REQUIRED) -> JailStatus:
    """Try the jail once with a real program run; cached for the life of the process."""
    if mode is JailMode.OFF:
        return JailStatus(mode, False, "the OS jail is switched off (PYSPATIAL_SANDBOX_JAIL=off)")
    if not sys.platform.startswith("linux"):
        return JailStatus(mode, False, f"the OS jail needs Linux namespaces; this is {sys.platform}")
    if shutil.which("bwrap") is None:
        return JailStatus(mode, False, "bubblewrap (bwrap) is not installed: apt-get install bubblewrap")
    problem = _probe_run()
    if problem:
        return JailStatus(mode, False, f"the OS jail could not start a program: {problem}")
    who = f"uid {SANDBOX_UID}" if os.geteuid() == 0 else f"uid {os.geteuid()} in a user namespace"
    return JailStatus(mode, True, f"bubblewrap namespaces, {who}, no capabilities, seccomp filter")


class _NoTools:
    """The probe's program calls no tool and returns no image."""

    limit_exceeded = False

    def handle(self, tool: object, arguments: object) -> object:
        raise ToolFailure("no tools in the probe")

    def image_bytes(self, handle: object) -> bytes:
        raise ProtocolError(f"unknown image handle {handle!r}")


def _probe_run() -> str | None:
    """Run one trivial program through the jailed worker; None when it worked, else what went wrong."""
    source = "def program(input_scene):\n    return 'jail ok'\n"
    limits = SandboxLimits(cpu_seconds=10, wall_seconds=20, memory_mb=1024, startup_seconds=30)
    job = job_message(source, "", 0, limits, python_checks=True)
    try:
        result = run_worker(jailed_worker_command(), "/", child_environment("/tmp"), job, _NoTools(), limits)
    except OSError as error:
        return f"{type(error).__name__}: {error}"
    if result.ok and result.clue_text == "jail ok":
        return None
    return clean_text(result.error) if result.error else "the probe program returned something else"


def announce(status: JailStatus) -> None:
    """Say at start-up, loudly when programs are not jailed."""
    if status.jailed:
        log.warning("sandbox: OS jail active (%s)", status.detail)
    elif status.mode is JailMode.OFF:
        log.error(
            "sandbox: OS JAIL SWITCHED OFF by PYSPATIAL_SANDBOX_JAIL=off: model-written programs run "
            "behind Python-level checks only. Do not expose this service to untrusted users."
        )
    else:
        log.error(
            "sandbox: OS JAIL UNAVAILABLE (%s): model-written programs will be REFUSED. Give the "
            "container what docs/ARCHITECTURE.md asks for, or set PYSPATIAL_SANDBOX_JAIL=off.",
            status.detail,
        )
