"""Session fixtures: a real Redis for the whole run.

REDIS_URL wins when set; otherwise the machine's Redis on 127.0.0.1:6379 is borrowed when it
answers (tests use their own key prefixes), and else a redis-server is started on a free port.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import atexit  # noqa: E402
import shutil  # noqa: E402
import tempfile  # noqa: E402

# Every service and command the tests start sees an empty hub cache and no hub: checkpoints a
# developer pulled into ~/.cache/huggingface never change what a test sees. Tests that pull
# (tests/test_weights_cli.py) set their own HF_HOME and HF_ENDPOINT.
os.environ["HF_HOME"] = tempfile.mkdtemp(prefix="pyspatial-test-hf-")
atexit.register(shutil.rmtree, os.environ["HF_HOME"], True)
os.environ["HF_HUB_OFFLINE"] = "1"
for _name in ("HF_HUB_CACHE", "HUGGINGFACE_HUB_CACHE", "HF_ENDPOINT"):
    os.environ.pop(_name, None)

from tests.support.processes import RedisServer, redis_answers, start_redis  # noqa: E402
from tests.support.scripted_llm import ScriptedLLM, start_scripted_llm  # noqa: E402


@pytest.fixture(scope="session")
def redis_server() -> Iterator[RedisServer]:
    candidates = [os.environ.get("REDIS_URL", ""), "redis://127.0.0.1:6379/0"]
    for url in filter(None, candidates):
        if redis_answers(url):
            yield RedisServer(url=url, process=None)
            return
    server = start_redis()
    try:
        yield server
    finally:
        server.stop()


@pytest.fixture(scope="session")
def redis_url(redis_server: RedisServer) -> str:
    return redis_server.url


@pytest.fixture(scope="module")
def llm() -> Iterator[ScriptedLLM]:
    """A local OpenAI-compatible server replaying scripted replies: the hosted model's stand-in."""
    server = start_scripted_llm()
    try:
        yield server
    finally:
        server.stop()
