"""The agent's sandbox budgets on their own: the cap on running sandboxes with its bounded queue, and
the CPU budget of one solve (through HTTP in tests/test_sandbox_http.py)."""

from __future__ import annotations

import threading
import time

import pytest

from services.agent.sandbox import SandboxLimits
from services.agent.sandbox_budget import CpuBudget, SandboxBusy, SandboxGate


def test_the_gate_admits_running_plus_waiting_solves_and_refuses_the_next() -> None:
    gate = SandboxGate(max_running=2, max_waiting=1, retry_after_s=7)
    tickets = [gate.admit() for _ in range(3)]
    with pytest.raises(SandboxBusy) as busy:
        gate.admit()
    assert busy.value.retry_after_s == 7
    assert str(busy.value) == (
        "busy: all 2 program sandboxes are running and 1 solves are waiting for one; retry in 7 s"
    )
    tickets[0].release()
    tickets[0].release()  # releasing twice frees one place only
    tickets.append(gate.admit())
    with pytest.raises(SandboxBusy):
        gate.admit()
    for ticket in tickets:
        ticket.release()
    assert gate.admitted == 0


def test_no_more_sandboxes_run_at_once_than_the_gate_allows() -> None:
    gate = SandboxGate(max_running=2, max_waiting=4, retry_after_s=1)
    running, most = [0], [0]
    lock = threading.Lock()

    def one_run() -> None:
        with gate.slot():
            with lock:
                running[0] += 1
                most[0] = max(most[0], running[0])
            time.sleep(0.05)
            with lock:
                running[0] -= 1

    threads = [threading.Thread(target=one_run) for _ in range(6)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert most[0] == 2


def test_the_cpu_budget_cuts_each_run_to_what_is_left_then_refuses_by_name() -> None:
    budget = CpuBudget(total_s=5)
    limits = SandboxLimits(cpu_seconds=3)
    assert budget.limits_for_next_run(limits).cpu_seconds == 3 and budget.spent_error() is None
    budget.charge(3.2)
    assert budget.limits_for_next_run(limits).cpu_seconds == 1  # 1.8 s left: whole seconds
    budget.charge(1.1)
    assert budget.spent_error() == (
        "cpu_budget: this solve's programs used 4.3 s of CPU, its budget is 5 s across all attempts; "
        "no further program runs"
    )
