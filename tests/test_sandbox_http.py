"""The sandbox through the real /v1/solve path: real recon and agent processes, real Redis, the
scripted language model as the only stand-in.

- the whole attack corpus (tests/test_sandbox_attacks.py), one agent, requests in parallel;
- the OS jail alone: an agent in the test-only unchecked mode runs the issue's escape programs while
  a concurrent ordinary /v1/solve succeeds, and the agent survives;
- an agent that cannot build the jail says so in /readyz and refuses programs with a 503.
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor

import httpx
import pytest

from services.agent.codegen import extract_program
from services.agent.program_cleanup import clean_program
from services.agent.sandbox.text import clean_text
from shared.local.services import running_service
from shared.wire.client import AgentClient, ReconClient
from tests.support.scenes import orbit_views
from tests.support.stack import recon_env
from tests.test_sandbox import FALSE_POSITIVES, FALSE_POSITIVES_CLUE
from tests.test_sandbox_attacks import ATTACKS, LIMITS, Attack
from tests.test_sandbox_jail import EPERM, attempt

RECON_APP = "services.recon.app:create_app"
AGENT_APP = "services.agent.app:create_app"
MOTION_PROGRAM = (
    "def program(input_scene):\n"
    "    recon = pySpatial.reconstruct(input_scene)\n"
    "    return pySpatial.describe_camera_motion(recon)\n"
)
QUESTION = "Which way did the camera move from view 1 to view 2? A. left B. right"


ANSWER_REPLY = '{"reasoning": "the clue says so", "answer": "A"}'


def script_answers(llm, count: int) -> None:
    llm.script([ANSWER_REPLY] * count, model="answerer")


def fenced(source: str) -> str:
    return f"Here is the program.\n```python\n{source}```\n"


def agent_env(recon_url: str, llm_url: str, **extra: str) -> dict[str, str]:
    return {
        "PYSPATIAL_RECON_URL": recon_url,
        "PYSPATIAL_CODE_MODEL": "coder",
        "PYSPATIAL_CODE_MODEL_BASE_URL": llm_url,
        # an answer model of its own, so that the code model's queue holds programs only
        "PYSPATIAL_ANSWER_MODEL": "answerer",
        "PYSPATIAL_ANSWER_MODEL_BASE_URL": llm_url,
        "PYSPATIAL_MODEL_TIMEOUT_S": "10",
        "PYSPATIAL_MODEL_MAX_RETRIES": "0",
        "PYSPATIAL_SANDBOX_CPU_S": str(LIMITS.cpu_seconds),
        "PYSPATIAL_SANDBOX_WALL_S": str(int(LIMITS.wall_seconds)),
        "PYSPATIAL_SANDBOX_MEMORY_MB": str(LIMITS.memory_mb),
        **extra,
    }


@pytest.fixture(scope="module")
def recon(tmp_path_factory, redis_url):
    env = recon_env(tmp_path_factory.mktemp("recon"), redis_url)
    with running_service(RECON_APP, env) as service:
        yield service


@pytest.fixture(scope="module")
def scene_id(recon) -> str:
    views = orbit_views(seed=7, num_views=2)
    with ReconClient(recon.url) as client:
        scene = client.upload_scene(
            views.pngs(), depths=views.depths, extrinsics=views.extrinsics, intrinsics=views.intrinsics
        ).scene_id
        client.reconstruct(scene, "posed-rgbd")  # cached before the timed requests
    return scene


def solve(url: str, scene_id: str, timeout: float = 120.0) -> httpx.Response:
    body = {"question": QUESTION, "scene_id": scene_id, "backbone": "posed-rgbd", "max_repairs": 0}
    return httpx.post(url + "/v1/solve", json=body, timeout=timeout)


def through_http(attack: Attack) -> bool:
    """Attacks the code model's reply can carry: a fenced block that defines program(), and text the
    scripted model server can send (it cannot send lone surrogates: its JSON is encoded as UTF-8)."""
    if "\x00" in attack.source or clean_text(attack.source) != attack.source:
        return False
    return extract_program(fenced(attack.source)) is not None


def test_the_attack_corpus_ends_the_same_way_through_v1_solve(recon, llm, scene_id) -> None:
    attacks = [attack for attack in ATTACKS if through_http(attack)]
    assert len(attacks) >= 150
    # and, as a control, the ordinary code that must never be refused
    attacks.append(Attack("false_positives", FALSE_POSITIVES, "ok", FALSE_POSITIVES_CLUE))
    llm.reset()
    llm.script([fenced(attack.source) for attack in attacks], model="coder")
    script_answers(llm, 2 * len(attacks))
    env = agent_env(recon.url, llm.base_url)
    with running_service(AGENT_APP, env) as agent:
        with ThreadPoolExecutor(max_workers=4) as pool:
            responses = list(pool.map(lambda _: solve(agent.url, scene_id), attacks))
        assert httpx.get(agent.url + "/healthz", timeout=5).status_code == 200
    by_program: dict[str, dict] = {}
    for response in responses:
        assert response.status_code == 200, response.text
        body = response.json()
        by_program[body["attempts"][0]["reply"]] = body
    problems = []
    for attack in attacks:
        body = by_program[fenced(attack.source)]  # replies are taken in arrival order
        attempt_record = body["attempts"][0]
        error, text = attempt_record["error"], body["clue"]["text"]
        cleaned = clean_program(attack.source)
        if cleaned.source.strip() != attack.source.strip():
            # codegen drops top-level code program() does not use before anything runs: the attack
            # never reaches the sandbox, and the response says what was dropped
            if attempt_record["program"].strip() != cleaned.source.strip():
                problems.append(f"{attack.name}: ran {attempt_record['program']!r}")
            if attempt_record["dropped"] != cleaned.dropped:
                problems.append(f"{attack.name}: dropped {attempt_record['dropped']!r}")
            continue
        if attack.kind == "ok":
            if error is not None or text != attack.reason:
                problems.append(f"{attack.name}: expected {attack.reason!r}, got {text!r} / {error!r}")
        # A failed attack's clue, if any, is the planner's program (labelled): never the attack's output.
        elif (
            error is None
            or attack.reason not in error
            or (text is not None and body["program_source"] != "planner")
        ):
            problems.append(f"{attack.name}: expected {attack.reason!r}, got {error!r} / {text!r}")
    assert problems == []


# The list: each must fail on the OS jail alone.
ESCAPES = {
    "kill_parent": ("os.kill(os.getppid(), 9)", EPERM),
    "fork": ("os.fork()", EPERM),
    "socket": ("socket.socket()", EPERM),
    "read_passwd": (
        "open('/etc/passwd').read()",
        "FileNotFoundError: [Errno 2] No such file or directory: '/etc/passwd'",
    ),
    "write_tmp": ("open('/tmp/x', 'w')", f"{EPERM}: '/tmp/x'"),
    "setsid": ("os.setsid()", EPERM),
    "subprocess": ("subprocess.run(['id'])", EPERM),
}


def test_the_jail_alone_holds_over_http_while_a_concurrent_solve_succeeds(recon, llm, scene_id) -> None:
    env = agent_env(recon.url, llm.base_url, PYSPATIAL_SANDBOX_TEST_ONLY_UNCHECKED="1")
    # Each escape first waits a moment, so that all of them and the ordinary solve run side by side.
    escapes = {name: attempt("import time", "time.sleep(1.0)", step) for name, (step, _) in ESCAPES.items()}
    llm.reset()
    llm.script([fenced(source) for source in escapes.values()], model="coder")
    script_answers(llm, 4 * len(escapes))
    with running_service(AGENT_APP, env) as agent:
        ready = httpx.get(agent.url + "/readyz", timeout=30).json()
        assert ready["sandbox"]["jail"] == "active" and ready["sandbox"]["runs_programs"] is True
        with ThreadPoolExecutor(max_workers=len(escapes) + 1) as pool:
            attacks = [pool.submit(solve, agent.url, scene_id) for _ in escapes]
            _wait_for_code_requests(llm, len(escapes))
            llm.script([fenced(MOTION_PROGRAM)], model="coder")
            ordinary = pool.submit(solve, agent.url, scene_id).result()
            bodies = [future.result().json() for future in attacks]
        assert ordinary.status_code == 200, ordinary.text
        assert ordinary.json()["attempts"][0]["error"] is None, ordinary.json()["attempts"]
        assert "moved" in ordinary.json()["clue"]["text"]
        assert httpx.get(agent.url + "/healthz", timeout=5).status_code == 200
        assert agent.process.poll() is None  # the agent survived every escape
    by_reply = {body["attempts"][0]["reply"]: body for body in bodies}
    for name, source in escapes.items():
        body = by_reply[fenced(source)]
        assert body["attempts"][0]["error"] is None, (name, body["attempts"][0]["error"])
        assert body["clue"]["text"] == ESCAPES[name][1], (name, body["attempts"])


def _wait_for_code_requests(llm, count: int) -> None:
    for _ in range(1200):
        if sum(request["model"] == "coder" for request in llm.requests()) >= count:
            return
        time.sleep(0.025)
    raise AssertionError("the agent never asked the code model")


def test_an_agent_without_a_jail_says_so_and_refuses_programs(recon, llm, scene_id) -> None:
    env = agent_env(recon.url, llm.base_url, PATH="/nonexistent")  # no bubblewrap to be found
    with running_service(AGENT_APP, env) as agent:
        ready = httpx.get(agent.url + "/readyz", timeout=30)
        assert ready.status_code == 503
        sandbox = ready.json()["sandbox"]
        assert sandbox == {
            "jail": "unavailable",
            "runs_programs": False,
            "detail": "bubblewrap (bwrap) is not installed: apt-get install bubblewrap",
        }
        response = solve(agent.url, scene_id)
        assert response.status_code == 503
        assert response.json()["detail"] == (
            "the program sandbox is unavailable: bubblewrap (bwrap) is not installed: "
            "apt-get install bubblewrap"
        )
        assert "OS JAIL UNAVAILABLE" in agent.log()


def test_an_operator_opt_out_runs_programs_and_says_so(recon, llm, scene_id) -> None:
    llm.reset()
    llm.script([fenced(MOTION_PROGRAM)], model="coder")
    script_answers(llm, 2)
    env = agent_env(recon.url, llm.base_url, PYSPATIAL_SANDBOX_JAIL="off")
    with running_service(AGENT_APP, env) as agent:
        ready = httpx.get(agent.url + "/readyz", timeout=30).json()
        assert ready["sandbox"]["jail"] == "off (operator opt-out)"
        with AgentClient(agent.url) as client:
            result = client.solve(QUESTION, scene_id=scene_id, backbone="posed-rgbd", max_repairs=0)
        assert result.attempts[0].error is None and "moved" in result.clue.text
        assert "OS JAIL SWITCHED OFF" in agent.log()


BURNER = "def program(input_scene):\n    n = {attempt}\n    while True:\n        n += 1\n"


def test_cpu_across_repairs_stops_at_the_solve_budget_and_a_full_agent_answers_503(
    recon, llm, scene_id
) -> None:
    # One sandbox and no queue: while a solve burns CPU through its repairs, the next one is a 503.
    env = agent_env(
        recon.url,
        llm.base_url,
        PYSPATIAL_SANDBOX_CPU_S="1",
        PYSPATIAL_SANDBOX_WALL_S="30",
        PYSPATIAL_SANDBOX_SOLVE_CPU_S="2",
        PYSPATIAL_SANDBOX_MAX_RUNNING="1",
        PYSPATIAL_SANDBOX_MAX_WAITING="0",
        PYSPATIAL_SANDBOX_RETRY_AFTER_S="9",
    )
    llm.reset()
    llm.script([fenced(BURNER.format(attempt=attempt)) for attempt in range(4)], model="coder")
    script_answers(llm, 4)
    body = {"question": QUESTION, "scene_id": scene_id, "backbone": "posed-rgbd", "max_repairs": 3}
    with running_service(AGENT_APP, env) as agent:
        with ThreadPoolExecutor(max_workers=1) as pool:
            burning = pool.submit(httpx.post, agent.url + "/v1/solve", json=body, timeout=120)
            _wait_for_code_requests(llm, 1)
            refused = solve(agent.url, scene_id)
            burnt = burning.result()
        code_requests = sum(request["model"] == "coder" for request in llm.requests())
        llm.script([fenced(MOTION_PROGRAM)], model="coder")
        after = solve(agent.url, scene_id)  # the ticket came back: admitted again
    assert refused.status_code == 503 and refused.headers["retry-after"] == "9"
    assert refused.json()["detail"].startswith("busy: all 1 program sandboxes are running")
    assert burnt.status_code == 200, burnt.text
    kinds = [attempt["error_kind"] for attempt in burnt.json()["attempts"]]
    errors = [attempt["error"] for attempt in burnt.json()["attempts"]]
    # two runs stopped by their 1 s CPU limit, then the budget (2 s) has less than a second left: the
    # third program is refused unrun and the solve ends there (no fourth request, no planner run)
    assert kinds == ["cpu", "cpu", "cpu_budget"], errors
    assert (
        errors[2].startswith("cpu_budget: this solve's programs used ") and "its budget is 2 s" in errors[2]
    )
    assert code_requests == 3
    assert burnt.json()["program_source"] is None and burnt.json()["code_model_fallback"] is None
    assert burnt.json()["fallback_reason"] == f"no program ran successfully: {errors[2]}"
    assert after.status_code == 200 and after.json()["attempts"][0]["error"] is None
