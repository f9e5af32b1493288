"""The OS jail on its own: programs run with every Python-level check switched off (test-only mode:
real builtins, the real numpy and os modules, no validator, no audit hook, no descriptor rlimit)
and still cannot kill, fork, connect, read the host's files, write, start a session, or start more
than a few threads (RLIMIT_NPROC, part of the OS layer).

Through the runner here; through /v1/solve of a real agent in tests/test_sandbox_http.py.
"""

from __future__ import annotations

import collections
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pyseccomp
import pytest

from services.agent.sandbox import SandboxLimits, run_program
from services.agent.sandbox.jail import (
    SANDBOX_UID,
    WORKDIR_PREFIX,
    JailMode,
    JailStatus,
    probe,
    python_path,
    remove_stale_workdirs,
)
from services.agent.sandbox.worker import MAX_TASKS
from services.agent.sandbox.worker_process import REPO_ROOT
from tests.test_sandbox_attacks import TinyTools

LIMITS = SandboxLimits(cpu_seconds=5, wall_seconds=10, memory_mb=512)
EPERM = "PermissionError: [Errno 1] Operation not permitted"


def attempt(*lines: str) -> str:
    """A program that tries `lines` and returns what happened, as text."""
    body = "".join(f"        {line}\n" for line in lines)
    return (
        "import os, socket, subprocess, ctypes, threading, resource\n"
        "def program(input_scene):\n"
        "    try:\n"
        f"{body}"
        "    except BaseException as error:\n"
        "        return f'{type(error).__name__}: {error}'\n"
        "    return 'allowed'\n"
    )


# The list first, then the rest of what the jail must refuse on its own.
JAIL_ALONE = {
    "kill_parent": (attempt("os.kill(os.getppid(), 9)"), EPERM),
    "fork": (attempt("os.fork()"), EPERM),
    "socket": (attempt("socket.socket()"), EPERM),
    "read_passwd": (
        attempt("open('/etc/passwd').read()"),
        "FileNotFoundError: [Errno 2] No such file or directory: '/etc/passwd'",
    ),
    "write_tmp": (attempt("open('/tmp/x', 'w')"), f"{EPERM}: '/tmp/x'"),
    "setsid": (attempt("os.setsid()"), EPERM),
    "subprocess": (attempt("subprocess.run(['id'])"), EPERM),
    # more of the same families
    "kill_init": (attempt("os.kill(1, signal_number := 9)"), EPERM),
    "kill_everyone": (attempt("os.kill(-1, 9)"), EPERM),
    "kill_group": (attempt("os.killpg(0, 9)"), EPERM),
    "system": (attempt("assert os.system('id') == 0"), "AssertionError: "),
    "posix_spawn": (attempt("os.posix_spawn('/usr/bin/id', ['id'], {})"), f"{EPERM}: '/usr/bin/id'"),
    "exec": (attempt("os.execv('/usr/bin/true', ['true'])"), EPERM),
    "connect_udp": (attempt("socket.create_connection(('127.0.0.1', 80), timeout=1)"), EPERM),
    "socketpair": (attempt("socket.socketpair()"), EPERM),
    "setpgid": (attempt("os.setpgid(0, 0)"), EPERM),
    "setuid_root": (attempt("os.setuid(0)"), EPERM),
    "raise_cpu_limit": (
        attempt("resource.setrlimit(resource.RLIMIT_CPU, (resource.RLIM_INFINITY, resource.RLIM_INFINITY))"),
        "ValueError: not allowed to raise maximum limit",
    ),
    "raise_soft_limit": (
        # soft up to hard needs no privilege: only the seccomp filter refuses it (Python turns the
        # EPERM into this ValueError)
        attempt(
            "soft, hard = resource.getrlimit(resource.RLIMIT_CPU)",
            "resource.setrlimit(resource.RLIMIT_CPU, (hard, hard))",
        ),
        "ValueError: not allowed to raise maximum limit",
    ),
    "append_stdlib": (attempt("open(socket.__file__, 'a')"), f"{EPERM}: '{socket.__file__}'"),
    "create_in_tmp": (attempt("os.open('/tmp/y', os.O_RDONLY | os.O_CREAT)"), f"{EPERM}: '/tmp/y'"),
    "mkdir_tmp": (attempt("os.mkdir('/tmp/d')"), f"{EPERM}: '/tmp/d'"),
    "read_repository": (
        attempt(f"open({str(REPO_ROOT / 'pyproject.toml')!r})"),
        f"FileNotFoundError: [Errno 2] No such file or directory: '{REPO_ROOT / 'pyproject.toml'}'",
    ),
    "read_home": (
        attempt("os.listdir('/home')"),
        "FileNotFoundError: [Errno 2] No such file or directory: '/home'",
    ),
    "threads_still_work": (
        attempt("t = threading.Thread(target=print)", "t.start()", "t.join()"),
        "allowed",
    ),
}


def run_unchecked(source: str, limits: SandboxLimits = LIMITS):
    return run_program(source, "q", 2, TinyTools(), limits, python_checks=False)


@pytest.mark.parametrize("name", list(JAIL_ALONE))
def test_the_jail_alone_refuses(name: str) -> None:
    source, expected = JAIL_ALONE[name]
    result = run_unchecked(source)
    assert result.ok, result.error
    assert result.clue_text == expected


def test_the_jail_is_what_the_docs_say() -> None:
    source = (
        "import os\n"
        "def program(input_scene):\n"
        "    status = dict(line.split(':\\t', 1) for line in open('/proc/self/status').read().splitlines()"
        " if ':\\t' in line)\n"
        "    devices = open('/proc/net/dev').read().splitlines()[2:]\n"
        "    interfaces = [line.split(':')[0].strip() for line in devices]\n"
        "    return {'uid': os.getuid(), 'gid': os.getgid(), 'pid_small': os.getpid() < 10,\n"
        "            'caps': [status[k].strip() for k in ('CapInh', 'CapPrm', 'CapEff', 'CapBnd',\n"
        "                                                 'CapAmb')],\n"
        "            'no_new_privs': status['NoNewPrivs'].strip(), 'seccomp': status['Seccomp'].strip(),\n"
        "            'interfaces': interfaces, 'cwd': os.getcwd(), 'tmp': os.listdir('/tmp'),\n"
        "            'etc': os.path.exists('/etc'), 'root_entries': sorted(os.listdir('/'))}\n"
    )
    result = run_unchecked(source)
    assert result.ok, result.error
    facts = dict(line.split(": ", 1) for line in result.clue_text.splitlines())
    expected_uid = SANDBOX_UID if os.geteuid() == 0 else os.geteuid()
    assert facts["uid"] == str(expected_uid)
    assert facts["pid_small"] == "True"  # its own PID namespace
    assert json.loads(facts["caps"]) == ["0000000000000000"] * 5
    assert facts["no_new_privs"] == "1" and facts["seccomp"] == "2"
    assert json.loads(facts["interfaces"]) == ["lo"]  # an empty network namespace
    # /tmp is a private, empty tmpfs; only the parents of read-only binds that lie under /tmp (a
    # checkout or a virtual environment there, as in a CI clone) show up in it.
    bound = [REPO_ROOT, Path(sys.base_prefix).resolve(), *map(Path, python_path())]
    under_tmp = {path.relative_to("/tmp").parts[0] for path in bound if path.is_relative_to("/tmp")}
    assert facts["cwd"] == "/tmp" and set(json.loads(facts["tmp"])) == under_tmp
    assert facts["etc"] == "False"
    assert set(json.loads(facts["root_entries"])) <= {
        "usr",
        "lib",
        "lib64",
        "lib32",
        "proc",
        "dev",
        "tmp",
    } | {Path(part).parts[1] for part in (sys.base_prefix, str(REPO_ROOT), json.__file__)}


THREAD_BOMB = """
import threading
def program(input_scene):
    threading.stack_size(64 * 1024)  # small stacks: the memory limit is not what stops it
    gate = threading.Event()
    started = 0
    try:
        for _ in range(3000):
            threading.Thread(target=gate.wait).start()
            started += 1
        outcome = 'all started'
    except RuntimeError as error:
        outcome = f'{type(error).__name__}: {error}'
    finally:
        gate.set()
    return f'{started} {outcome}'
"""


def test_a_thread_bomb_stops_at_the_task_limit_with_the_python_checks_off() -> None:
    # RLIMIT_NPROC, counted by the kernel for the worker's (never root) user: the worker itself is
    # one of those tasks, and as host uid 65534 so is every other sandbox running right now.
    result = run_unchecked(THREAD_BOMB)
    assert result.ok, result.error
    started, outcome = result.clue_text.split(" ", 1)
    assert outcome == "RuntimeError: can't start new thread"
    assert int(started) < MAX_TASKS
    uncaught = run_unchecked(THREAD_BOMB.replace("except RuntimeError", "except ZeroDivisionError"))
    assert not uncaught.ok and uncaught.error_kind == "exception"
    assert uncaught.error == (
        "program raised RuntimeError: can't start new thread (the sandbox allows at most "
        f"{MAX_TASKS} threads and processes) (line 9)"
    )
    # the host is unaffected: the next program starts threads again (the bomb's worker is gone)
    after = run_unchecked(attempt("t = threading.Thread(target=print)", "t.start()", "t.join()"))
    assert after.ok and after.clue_text == "allowed", after.error


def test_a_crash_is_reported_as_what_it_was() -> None:
    result = run_unchecked("import ctypes\ndef program(input_scene):\n    return ctypes.string_at(0)\n")
    assert not result.ok and result.error_kind == "crash"
    assert result.error == (
        "the sandbox process crashed with SIGSEGV (Segmentation fault) while running program line 3"
    )


def frame(body: str) -> str:
    """Python source of one length-prefixed frame holding `body` (bytes source)."""
    return f"(lambda b: len(b).to_bytes(4, 'big') + b)({body})"


RESULT = 'b\'{"type":"result","ok":true,"text":"forged","images":[],"stdout":""}\''
FORGERIES = {
    # framing: lengths, cut-off frames, raw lines
    "huge_length": ("(0xFFFFFFFF).to_bytes(4, 'big')", "a frame announced 4294967295 bytes; the limit is"),
    "length_past_cap": ("(2_000_000).to_bytes(4, 'big') + b'{'", "a frame announced 2000000 bytes"),
    "json_line": (RESULT + " + b'\\n'", "a frame announced 2065855609 bytes"),
    "endless_stream": ("b'x' * (8 << 20)", "a frame announced 2021161080 bytes"),
    # content: strict ASCII JSON objects
    "deep_line": (frame("b'[' * 400000"), "malformed message: nested more than 64 levels"),
    "deep_object": (frame("b'{\"a\":' * 5000 + b'1' + b'}' * 5000"), "nested more than 64 levels"),
    # a string that never closes: 160 KB of it held the parent (and its GIL) for 112 s before the
    # depth check became linear (issue 38)
    "unterminated_string": (frame("b'\"' + b'\\\\\"' * 80_000"), "malformed message: Unterminated string"),
    "not_json": (frame("b'{not json}'"), "malformed message: Expecting property name"),
    "not_an_object": (frame("b'[1, 2]'"), "a message must be a JSON object with a 'type'"),
    "bad_utf8": (frame('b\'{"type": "result", "ok": true, "text": "\\xff"}\''), "must be ASCII JSON"),
    "utf8_not_ascii": (
        frame('\'{"type": "result", "ok": true, "text": "é"}\'.encode()'),
        "must be ASCII JSON",
    ),
    # schema
    "unknown_type": (frame('b\'{"type": "hello"}\''), "unexpected message type 'hello'"),
    "extra_field": (frame(RESULT[:-2] + ',"admin":true}\''), "invalid result message: admin: Extra inputs"),
    "ok_as_number": (frame('b\'{"type":"result","ok":1}\''), "invalid result message: ok: Input should be"),
    "text_not_string": (frame('b\'{"type":"result","ok":true,"text":[1]}\''), "result message: text"),
    "stdout_not_string": (
        frame('b\'{"type":"result","ok":false,"kind":"exception","error":"x","stdout":[[1]]}\''),
        "invalid result message: stdout",
    ),
    "unknown_kind": (
        frame('b\'{"type":"result","ok":false,"kind":"jail","error":"x"}\''),
        "result message: kind",
    ),
    "failure_without_kind": (frame('b\'{"type":"result","ok":false,"error":"x"}\''), "must name its kind"),
    "unknown_tool": (frame('b\'{"type":"call","tool":"os.system","arguments":{}}\''), "call message: tool"),
    "forged_image": (
        frame('b\'{"type":"result","ok":true,"text":"t","images":["view:99"]}\''),
        "unknown image handle 'view:99'",
    ),
    # order: the conversation has one ready, then calls, then one result
    "second_ready": (
        frame('b\'{"type":"ready"}\''),
        "a 'ready' message out of order (expected call or result)",
    ),
}


@pytest.mark.parametrize("name", list(FORGERIES))
def test_forged_protocol_lines_are_a_clean_program_error(name: str) -> None:
    payload, reason = FORGERIES[name]
    # The worker's private protocol writer is the second descriptor it duplicated (fd 4).
    source = f"import os\ndef program(input_scene):\n    os.write(4, {payload})\n    os._exit(0)\n"
    started = time.perf_counter()
    result = run_unchecked(source)
    assert not result.ok and result.error_kind == "crash", result.error
    assert result.error.startswith("the sandbox broke its protocol: ") and reason in result.error
    assert time.perf_counter() - started < 10  # bounded parent work (generous: a shared 2-core machine)


def test_unchecked_mode_is_refused_without_the_jail() -> None:
    opted_out = JailStatus(JailMode.OFF, False, "off")
    with pytest.raises(ValueError, match="only be switched off inside the OS jail"):
        run_program(
            "def program(input_scene):\n    return 1\n", "q", 1, TinyTools(), LIMITS, opted_out, False
        )


def test_without_a_jail_programs_are_refused_unless_the_operator_opts_out() -> None:
    unavailable = JailStatus(JailMode.REQUIRED, False, "bubblewrap (bwrap) is not installed")
    source = "def program(input_scene):\n    return 1\n"
    refused = run_program(source, "q", 1, TinyTools(), LIMITS, unavailable)
    assert not refused.ok and refused.error_kind == "jail"
    assert refused.error.startswith(
        "refused: the OS sandbox is unavailable (bubblewrap (bwrap) is not installed)"
    )
    opted_out = run_program(source, "q", 1, TinyTools(), LIMITS, probe(JailMode.OFF))
    assert opted_out.ok and opted_out.clue_text == "1"
    assert probe(JailMode.REQUIRED).jailed, probe(JailMode.REQUIRED).detail


KILLED_PARENT_SCRIPT = """
import json, os, sys, threading, time
sys.path.insert(0, sys.argv[1])
from services.agent.sandbox import SandboxLimits, run_program
from tests.test_sandbox_attacks import TinyTools

source = "def program(input_scene):\\n    while True:\\n        pass\\n"
limits = SandboxLimits(cpu_seconds=60, wall_seconds=60)
threading.Thread(target=run_program, args=(source, "q", 1, TinyTools(), limits), daemon=True).start()

def descendants(root):
    children = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                fields = open(f"/proc/{entry}/stat").read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            children.setdefault(int(fields[1]), []).append(int(entry))
    found, queue = [], [root]
    while queue:
        for child in children.get(queue.pop(), []):
            found.append(child)
            queue.append(child)
    return found

for _ in range(300):
    found = descendants(os.getpid())
    if len(found) >= 3:  # bubblewrap, its namespace init, the worker
        time.sleep(0.5)  # the program is spinning
        print(json.dumps(descendants(os.getpid())), flush=True)
        break
    time.sleep(0.05)
time.sleep(60)
"""


def test_a_killed_agent_leaves_no_sandbox_process_behind() -> None:
    parent = subprocess.Popen(
        [sys.executable, "-c", KILLED_PARENT_SCRIPT, str(REPO_ROOT)], stdout=subprocess.PIPE, text=True
    )
    try:
        pids = json.loads(parent.stdout.readline())
        assert len(pids) >= 3
        assert all(Path(f"/proc/{pid}").exists() for pid in pids)
    finally:
        parent.send_signal(signal.SIGKILL)
        parent.wait()
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and any(_alive(pid) for pid in pids):
        time.sleep(0.1)
    assert not any(_alive(pid) for pid in pids), [_describe(pid) for pid in pids]


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def _describe(pid: int) -> str:
    try:
        return f"{pid}: {Path(f'/proc/{pid}/cmdline').read_bytes()[:80]!r}"
    except OSError:
        return f"{pid}: gone"


CHECKOUT_UNDER_TMP_SCRIPT = """
import sys
sys.path.insert(0, sys.argv[1])
from services.agent.sandbox import SandboxLimits, run_program
from services.agent.sandbox.jail import JailMode, probe
from tests.test_sandbox_attacks import TinyTools

jail = probe(JailMode.REQUIRED)
assert jail.jailed, jail.detail
source = "def program(input_scene):\\n    return str(len(input_scene.images))\\n"
result = run_program(source, "q", 2, TinyTools(), SandboxLimits(), jail)
print(result.ok, result.clue_text, result.error)
"""


def test_the_jail_works_for_a_checkout_under_tmp() -> None:
    """The jail's private /tmp must not hide a checkout (or CI's clone) that lies under /tmp."""
    with tempfile.TemporaryDirectory(dir="/tmp") as root:
        copy = Path(root) / "checkout"
        ignore = shutil.ignore_patterns("__pycache__", "data")
        for part in ("services", "shared", "tests"):
            shutil.copytree(REPO_ROOT / part, copy / part, ignore=ignore)
        finished = subprocess.run(
            [sys.executable, "-c", CHECKOUT_UNDER_TMP_SCRIPT, str(copy)],
            capture_output=True, text=True, timeout=120, cwd=root,
        )  # fmt: skip
        assert finished.returncode == 0, finished.stderr[-2000:]
        assert finished.stdout.split()[:2] == ["True", "2"], finished.stdout + finished.stderr[-2000:]


def test_stale_workdirs_of_dead_agents_are_removed_and_live_ones_kept() -> None:
    with tempfile.TemporaryDirectory() as root:
        dead = Path(root, f"{WORKDIR_PREFIX}999999999-abc")  # no such process
        legacy = Path(root, f"{WORKDIR_PREFIX}k3j4h5")  # older name without an owner
        mine = Path(root, f"{WORKDIR_PREFIX}{os.getpid()}-xyz")
        other = Path(root, "unrelated")
        for directory in (dead, legacy, mine, other):
            directory.mkdir()
        (dead / "leftover.txt").write_text("x")
        assert remove_stale_workdirs(root) == 2
        assert sorted(p.name for p in Path(root).iterdir()) == sorted([mine.name, other.name])


# --- the OS layer alone, by attack class: each class is one program (one worker) trying every route ---
ROUTE_PROGRAM = """
import ctypes, errno, json, mmap, os, stat, threading
libc = ctypes.CDLL(None, use_errno=True)

SYSCALLS = {syscalls}

def raw(name, *arguments):
    value = libc.syscall(SYSCALLS[name], *arguments)
    if value == -1:
        raise OSError(ctypes.get_errno(), 'refused')
    return value

def outcome(action):
    try:
        action()
    except OSError as error:
        return errno.errorcode.get(error.errno, str(error.errno))
    except BaseException as error:
        return type(error).__name__
    return 'allowed'

def many_threads(stack_mb, count):
    threading.stack_size(stack_mb << 20)
    gate = threading.Event()
    started = []
    try:
        for _ in range(count):
            thread = threading.Thread(target=gate.wait)
            thread.start()
            started.append(thread)
    finally:
        gate.set()
        for thread in started:
            thread.join()

def fds():
    kinds = {{}}
    for fd in sorted(int(name) for name in os.listdir('/proc/self/fd')):
        try:
            mode = os.fstat(fd).st_mode
        except OSError:
            continue  # the listing's own descriptor, closed again
        kinds[fd] = 'pipe' if stat.S_ISFIFO(mode) else 'char' if stat.S_ISCHR(mode) else 'other'
    return kinds

ROUTES = {routes}

def program(input_scene):
    return json.dumps({{name: outcome(action) for name, action in ROUTES.items()}})
"""
GiB = 1 << 30
# Raw syscalls by name (their numbers are this machine's, from libseccomp): they reach what no
# Python module wraps
ROUTE_CLASSES = {
    "memory": {  # 512 MB limit: every route to 1 GiB fails, and 64 MB still works (the limit is real)
        "small_allocation": ("lambda: bytearray(64 << 20)", "allowed"),
        "bytearray": (f"lambda: bytearray({GiB})", "MemoryError"),
        "mmap_private": (f"lambda: mmap.mmap(-1, {GiB})", "ENOMEM"),
        "mmap_shared": (f"lambda: mmap.mmap(-1, {GiB}, flags=mmap.MAP_SHARED)", "ENOMEM"),
        "sysv_shmget": (f"lambda: raw('shmget', 0, ctypes.c_size_t({GiB}), 0o1600 | 0o1000)", "EPERM"),
        "sysv_shmget_small": ("lambda: raw('shmget', 0, ctypes.c_size_t(4096), 0o1600 | 0o1000)", "EPERM"),
        "sysv_shmat": ("lambda: raw('shmat', 0, 0, 0)", "EPERM"),
        "sysv_msgget": ("lambda: raw('msgget', 0, 0o1600 | 0o1000)", "EPERM"),
        "sysv_semget": ("lambda: raw('semget', 0, 1, 0o1600 | 0o1000)", "EPERM"),
        "memfd_create": ("lambda: os.memfd_create('x')", "EPERM"),
        "memfd_raw": ("lambda: raw('memfd_create', ctypes.c_char_p(b'x'), 0)", "EPERM"),
        "pipe_buffers": ("lambda: os.pipe()", "EPERM"),
        "eventfd": ("lambda: os.eventfd(0)", "EPERM"),
        "tmpfs_file": ("lambda: open('/tmp/fill', 'wb')", "EPERM"),
        "dev_shm_file": ("lambda: open('/dev/shm/fill', 'wb')", "EPERM"),
        "thread_stacks": ("lambda: many_threads(256, 4)", "RuntimeError"),
        "userfaultfd": ("lambda: raw('userfaultfd', 0)", "EPERM"),
        "io_uring_setup": ("lambda: raw('io_uring_setup', 8, ctypes.create_string_buffer(120))", "EPERM"),
    },
    "kernel_facilities": {
        "bpf": ("lambda: raw('bpf', 0, 0, 0)", "EPERM"),
        "perf_event_open": ("lambda: raw('perf_event_open', 0, 0, -1, -1, 0)", "EPERM"),
        "keyctl": ("lambda: raw('keyctl', 0, 0)", "EPERM"),
        "ptrace": ("lambda: raw('ptrace', 16, 1, 0, 0)", "EPERM"),
        "process_vm_readv": ("lambda: raw('process_vm_readv', 1, 0, 0, 0, 0, 0)", "EPERM"),
        "mount": ("lambda: raw('mount', 0, 0, 0, 0, 0)", "EPERM"),
        "unshare": ("lambda: raw('unshare', 0x10000000)", "EPERM"),
        "setns": ("lambda: raw('setns', 0, 0)", "EPERM"),
        "personality": ("lambda: raw('personality', 0x0040000)", "EPERM"),
        "socket_raw": ("lambda: raw('socket', 2, 1, 0)", "EPERM"),
        "clone_process": ("lambda: raw('clone', 17, 0, 0, 0, 0)", "EPERM"),
        "clone3": ("lambda: raw('clone3', 0, 0)", "ENOSYS"),
    },
    "signals_to_the_parent": {
        "kill_parent": ("lambda: os.kill(os.getppid(), 9)", "EPERM"),
        "kill_group": ("lambda: os.kill(0, 9)", "EPERM"),
        "tgkill_parent": ("lambda: raw('tgkill', os.getppid(), os.getppid(), 9)", "EPERM"),
        "rt_sigqueueinfo": (
            "lambda: raw('rt_sigqueueinfo', os.getppid(), 9, ctypes.create_string_buffer(128))",
            "EPERM",
        ),
        "pidfd_open": ("lambda: raw('pidfd_open', os.getppid(), 0)", "EPERM"),
        "pdeathsig_off": ("lambda: raw('prctl', 1, 0)", "EPERM"),
        "own_signal_ok": ("lambda: raw('tgkill', os.getpid(), os.getpid(), 0)", "allowed"),
    },
    "proc": {
        "write_own_mem": ("lambda: open('/proc/self/mem', 'r+b')", "EPERM"),
        "sysrq_trigger": ("lambda: open('/proc/sysrq-trigger', 'w')", "EPERM"),
        "parent_environ": ("lambda: open(f'/proc/{os.getppid()}/environ', 'rb').read()", "EACCES"),
        "parent_root": ("lambda: os.listdir(f'/proc/{os.getppid()}/root/')", "EACCES"),
        "parent_mem": ("lambda: open(f'/proc/{os.getppid()}/mem', 'rb')", "EACCES"),
        "kernel_knob": ("lambda: open('/proc/sys/kernel/core_pattern', 'w')", "EPERM"),
    },
}


def route_program(routes: str) -> str:
    """The route program with this machine's numbers for the syscalls it calls by name."""
    named = sorted(set(re.findall(r"raw\('(\w+)'", routes)))
    arch = pyseccomp.system_arch()
    numbers = {name: pyseccomp.resolve_syscall(arch, name) for name in named}
    return ROUTE_PROGRAM.format(routes=routes, syscalls=repr(numbers))


@pytest.mark.parametrize("route_class", list(ROUTE_CLASSES))
def test_the_jail_alone_closes_every_route_of_a_class(route_class: str) -> None:
    routes = ROUTE_CLASSES[route_class]
    table = "{" + ", ".join(f"{name!r}: {action}" for name, (action, _) in routes.items()) + "}"
    result = run_unchecked(route_program(table))
    assert result.ok, result.error
    assert json.loads(result.clue_text) == {name: expected for name, (_, expected) in routes.items()}


def test_the_jail_alone_inherits_only_its_protocol_descriptors() -> None:
    source = route_program("{}").replace("return json.dumps({name", "return json.dumps(fds()) or ({name")
    result = run_unchecked(source)
    assert result.ok, result.error
    # 0 and 1 are /dev/null, 2 the stderr pipe, 3 and 4 the protocol pipes: nothing else of the
    # host (no listening socket, no open file of the agent) reaches the worker.
    assert json.loads(result.clue_text) == {"0": "char", "1": "char", "2": "pipe", "3": "pipe", "4": "pipe"}


STDERR_PROGRAM = """import os, sys
def program(input_scene):
    sys.stderr.write('Traceback (most recent call last):\\n'
                     '  File "/root/.pyenv/versions/3.12.7/lib/python3.12/json/decoder.py", line 5, in f\\n'
                     '  File "<program>", line 3, in program\\n'
                     'Python 3.12.7 (main) [GCC 12.2.0] ' + 'x' * 10000 + '\\n'
                     'json.decoder.JSONDecodeError: bad /srv/agent/secrets/key.pem at 0x7f00deadbeef\\n')
    sys.stderr.flush()
    os._exit(3)
"""


def test_the_workers_stderr_reaches_the_model_only_scrubbed(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level("WARNING", logger="pyspatial.sandbox"):
        result = run_unchecked(STDERR_PROGRAM)
    assert not result.ok and result.error_kind == "crash"
    assert result.error == (
        "the sandbox process exited with status 3 without a result: (JSONDecodeError: bad <path> at 0x…) "
        "while running program line 3"
    )
    logged = "\n".join(record.getMessage() for record in caplog.records)
    assert "/srv/agent/secrets/key.pem" in logged and "3.12.7" in logged  # the full text, for operators


QUICK = SandboxLimits(cpu_seconds=1, wall_seconds=1.5, memory_mb=512)  # endings do not matter here


@pytest.mark.parametrize(
    "share", [pytest.param(10, id="every_tenth"), pytest.param(1, id="all", marks=pytest.mark.slow)]
)
def test_the_attack_corpus_behind_the_os_layer_alone_reaches_nothing_of_the_host(
    tmp_path, share: int
) -> None:
    """tests/test_sandbox_attacks.py's corpus with every Python-level check off (real builtins, real
    numpy): whatever each program manages inside, nothing of the host may come out or change. The
    host holds a secret in a file outside the jail's view and in the agent's environment. Every
    tenth attack in the default run (about 25 programs); all of them with `pytest -m slow` (~1 min).
    The OS layer's own classes (JAIL_ALONE, ROUTE_CLASSES, FORGERIES above) run in full by default."""
    from concurrent.futures import ThreadPoolExecutor

    from tests.test_sandbox_attacks import ATTACKS

    attacks = ATTACKS[::share]

    secret = f"pyspatial-canary-{os.getpid()}-{time.time_ns()}"
    (tmp_path / "secret.txt").write_text(secret)
    os.environ["PYSPATIAL_TEST_CANARY"] = secret
    host_tmp_before = set(os.listdir("/tmp"))
    try:
        with ThreadPoolExecutor(max_workers=4) as pool:
            results = list(pool.map(lambda attack: run_unchecked(attack.source, QUICK), attacks))
    finally:
        del os.environ["PYSPATIAL_TEST_CANARY"]
    leaks = [
        attack.name
        for attack, result in zip(attacks, results, strict=True)
        if any(secret in (text or "") for text in (result.clue_text, result.stdout, result.error))
    ]
    assert leaks == []
    created = {
        name for name in set(os.listdir("/tmp")) - host_tmp_before if name.startswith("pyspatial-sandbox")
    }
    assert created == set()  # the jail's /tmp is its own tmpfs
    # every kind of ending, none of them the agent's: the corpus really ran unchecked
    kinds = collections.Counter(result.error_kind for result in results)
    assert kinds[None] and kinds["exception"], kinds  # the programs really ran, unchecked


def test_a_crash_the_worker_reports_reaches_the_model_without_its_paths() -> None:
    error = "the sandbox failed: OSError: /usr/lib/python3/x.py"
    body = '{"type":"result","ok":false,"kind":"crash","error":"' + error + '"}'
    payload = frame(f"b{body!r}")
    result = run_unchecked(
        f"import os\ndef program(input_scene):\n    os.write(4, {payload})\n    os._exit(0)\n"
    )
    assert not result.ok and result.error_kind == "crash"
    assert result.error == "the sandbox failed: OSError: <path>"
