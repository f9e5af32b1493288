"""A cancelled solve stops its work: the step log, the sandbox process, the model call.

Real sandbox processes (the OS jail as the machine provides it) and the scripted local model server
(the one stand-in) over real HTTP; the browser's Cancel button is tested in tests/test_web_page.py.
"""

from __future__ import annotations

import threading
import time

import psutil
import pytest

from services.agent.cancellation import Cancellation, SolveCancelled, bound
from services.agent.llm import ChatClient, ChatModelConfig
from services.agent.sandbox import SandboxLimits, run_program
from services.agent.steps import SolveLog
from shared.wire.schemas import ExecutionStep, SceneStep
from tests.support.scripted_llm import ScriptedLLM
from tests.test_sandbox import PointSceneTools

# It asks for the reconstruction first: the parent sees that call, so the test knows the program
# itself is running (past the jail's start) before it cancels.
ENDLESS = """
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    total = 0
    for i in range(10 ** 7):
        for j in range(10 ** 7):
            total += 1
    return str(total)
"""
# From the cancellation to the run's end with its processes gone. The program would otherwise run to
# its 60 s limits; the bound leaves room for a loaded machine (a dying process is reaped late there).
KILL_LATENCY_S = 5.0


class SignallingTools(PointSceneTools):
    """The point scene's tools, telling the test when the program makes its first call."""

    def __init__(self) -> None:
        super().__init__()
        self.called = threading.Event()

    def reconstruct(self) -> dict:
        self.called.set()
        return super().reconstruct()


def _sandbox_workers() -> list[psutil.Process]:
    """This process's sandbox workers now running (bubblewrap and the Python inside it)."""
    found = []
    for child in psutil.Process().children(recursive=True):
        try:
            if "services.agent.sandbox.worker" in " ".join(child.cmdline()):
                found.append(child)
        except psutil.Error:  # it ended while we looked
            continue
    return found


def _running(process: psutil.Process) -> bool:
    try:
        return process.is_running() and process.status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


def test_callbacks_run_once_and_late_ones_at_once():
    cancellation, calls = Cancellation(), []
    with cancellation.on_cancel(lambda: calls.append("during")):
        cancellation.cancel("the client went away")
        cancellation.cancel("again")
    assert calls == ["during"] and cancellation.reason == "the client went away"
    with cancellation.on_cancel(lambda: calls.append("late")):
        pass
    assert calls == ["during", "late"] and cancellation.wait(10)
    with pytest.raises(SolveCancelled, match="cancelled: the client went away"):
        cancellation.check()


def test_the_log_starts_no_step_once_cancelled_and_aborts_the_running_one():
    cancellation = Cancellation()
    log = SolveLog(cancellation=cancellation)
    moments = []
    log.callbacks.register(SceneStep, lambda step, moment: moments.append(moment))
    with pytest.raises(SolveCancelled):
        with log.record(SceneStep(uploaded_images=1)) as step:
            cancellation.cancel()
            step.error = "what the stopped work said"
    assert moments == ["started", "aborted"] and step.error == "cancelled: the client went away"
    with pytest.raises(SolveCancelled):
        with log.record(ExecutionStep(run=1, attempt=1)):
            raise AssertionError("a step started after the cancellation")


def test_a_cancelled_program_is_killed_at_once():
    cancellation, tools = Cancellation(), SignallingTools()
    limits = SandboxLimits(cpu_seconds=60, wall_seconds=60, memory_mb=1024)
    workers: list[psutil.Process] = []
    cancelled_at: list[float] = []

    def cancel_while_it_runs() -> None:
        if tools.called.wait(timeout=60):  # a loaded machine starts the jail slowly
            time.sleep(0.3)  # the reply is back and the loop spinning
            workers.extend(_sandbox_workers())
        cancelled_at.append(time.monotonic())
        cancellation.cancel()

    canceller = threading.Thread(target=cancel_while_it_runs)
    canceller.start()
    result = run_program(ENDLESS, "q", 3, tools, limits, cancel=cancellation)
    returned_at = time.monotonic()
    canceller.join()
    assert tools.called.is_set() and workers, "the program never ran"
    assert not result.ok
    assert returned_at - cancelled_at[0] < KILL_LATENCY_S, "the run went on after the cancellation"
    while any(_running(worker) for worker in workers):
        assert time.monotonic() - cancelled_at[0] < KILL_LATENCY_S, "a sandbox process outlived the cancel"
        time.sleep(0.02)


def test_a_cancelled_model_call_is_abandoned(llm: ScriptedLLM):
    llm.reset()
    llm.script([{"text": "late", "delay_s": 30}])
    config = ChatModelConfig(base_url=llm.base_url, model="coder", timeout_s=60, max_retries=2)
    cancellation, outcome = Cancellation(), {}

    def call() -> None:
        with bound(cancellation), ChatClient(config) as client:
            try:
                client.complete([{"role": "user", "content": "hello"}])
            except SolveCancelled as error:
                outcome["error"] = error

    caller = threading.Thread(target=call)
    caller.start()
    deadline = time.monotonic() + 10
    while not llm.requests():
        assert time.monotonic() < deadline
        time.sleep(0.05)
    cancelled_at = time.monotonic()
    cancellation.cancel()
    caller.join(timeout=10)
    assert not caller.is_alive() and isinstance(outcome.get("error"), SolveCancelled)
    assert time.monotonic() - cancelled_at < 2  # not after the 30 s reply, and no retry
    deadline = time.monotonic() + 5
    while not llm.requests()[-1]["client_left"]:
        assert time.monotonic() < deadline, "the model server never saw the client leave"
        time.sleep(0.05)
    assert len(llm.requests()) == 1
