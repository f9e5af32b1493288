"""How the agent serves its page, over real HTTP: security headers, Subresource Integrity, cache
lifetimes, compression (the solve's events still arrive live through it), the examples, the
reconstruction's download, and a solve stopped when its client goes away.

Real recon and agent processes, real Redis; the code model is the scripted local server.
"""

from __future__ import annotations

import base64
import hashlib
import json
import re
import time

import httpx
import psutil
import pytest

from shared.local.services import REPO_ROOT, running_service
from tests.support.scenes import orbit_views
from tests.support.stack import recon_env, upload_posed_views

WEB_DIR = REPO_ROOT / "services" / "agent" / "web"
SSE = {"Accept": "text/event-stream"}
QUESTION = "Which way did the camera move from view 1 to view 2? A. Left B. Right C. Forward D. Backward"
ENDLESS_PROGRAM = """```python
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    total = 0
    for i in range(10 ** 7):  # the sandbox allows ranges of up to 10 million items
        for j in range(10 ** 7):
            total += 1
    return str(total)
```"""
MOTION_PROGRAM = """```python
def program(input_scene):
    return pySpatial.describe_camera_motion(pySpatial.reconstruct(input_scene))
```"""


@pytest.fixture(scope="module")
def recon(tmp_path_factory, redis_url):
    env = recon_env(tmp_path_factory.mktemp("recon"), redis_url)
    with running_service("services.recon.app:create_app", env) as service:
        yield service


@pytest.fixture(scope="module")
def agent(recon, llm):
    env = {
        "PYSPATIAL_RECON_URL": recon.url,
        "PYSPATIAL_CODE_MODEL": "coder",
        "PYSPATIAL_CODE_MODEL_BASE_URL": llm.base_url,
        "PYSPATIAL_ANSWER_MODEL": "",
        "PYSPATIAL_MODEL_MAX_RETRIES": "0",
    }
    with running_service("services.agent.app:create_app", env) as service:
        yield service


@pytest.fixture(scope="module")
def scene_id(recon) -> str:
    return upload_posed_views(recon.url, orbit_views(seed=7, num_views=3))


def sri(data: bytes) -> str:
    return "sha384-" + base64.b64encode(hashlib.sha384(data).digest()).decode()


def test_every_page_response_has_the_security_headers_and_its_cache_lifetime(agent):
    page = httpx.get(agent.url + "/")
    policy = dict(
        (directive.split(" ", 1) + [""])[:2]
        for directive in page.headers["content-security-policy"].split("; ")
    )
    assert policy["default-src"] == "'none'"
    assert re.fullmatch(r"'self' 'sha256-[A-Za-z0-9+/=]{44}'", policy["script-src"])  # no 'unsafe-inline'
    assert policy["connect-src"] == "'self'"
    assert policy["frame-ancestors"] == policy["object-src"] == policy["base-uri"] == "'none'"
    assert "unsafe" not in page.headers["content-security-policy"]
    assert page.headers["cache-control"] == "no-cache"
    responses = {
        "/": page,
        "/web/app.js": httpx.get(agent.url + "/web/app.js"),
        "/web/vendor/three-0.187.0/three.core.js": httpx.get(
            agent.url + "/web/vendor/three-0.187.0/three.core.js"
        ),
        "/web/missing.js": httpx.get(agent.url + "/web/missing.js"),
        "/healthz": httpx.get(agent.url + "/healthz"),
        "/v1/examples": httpx.get(agent.url + "/v1/examples"),
    }
    for path, response in responses.items():
        assert response.headers["x-content-type-options"] == "nosniff", path
        assert response.headers["referrer-policy"] == "no-referrer", path
        assert response.headers["x-frame-options"] == "DENY", path
        if path == "/" or path.startswith("/web/"):
            assert response.headers["content-security-policy"] == page.headers["content-security-policy"], (
                path
            )
    assert responses["/web/app.js"].headers["cache-control"] == "no-cache"
    assert "etag" in responses["/web/app.js"].headers  # revalidated, not downloaded again
    vendor = responses["/web/vendor/three-0.187.0/three.core.js"]
    assert vendor.headers["cache-control"] == "public, max-age=31536000, immutable"
    assert responses["/web/missing.js"].status_code == 404
    assert "cache-control" not in responses["/web/missing.js"].headers  # a 404 is not kept for a year


def test_every_tag_and_module_carries_integrity_of_what_is_served(agent):
    html = httpx.get(agent.url + "/").text
    tags = re.findall(r"<(?:script|link)\b[^>]*>", html)
    urls = []
    for tag in tags:
        source = re.search(r'(?:src|href)="([^"]+)"', tag)
        if source is None:
            assert 'type="importmap"' in tag  # the one inline script: JSON, allowed by its hash
            continue
        served = httpx.get(agent.url + source.group(1)).content
        assert f'integrity="{sri(served)}"' in tag, tag
        urls.append(source.group(1))
    assert {"/web/app.js", "/web/style.css", "/web/vendor/highlight-11.11.1/highlight.min.js"} <= set(urls)
    import_map = json.loads(re.search(r'<script type="importmap">(.*?)</script>', html, re.DOTALL).group(1))
    # Every module the page can import (followed from app.js through the import map) has its hash there.
    pending, seen = ["/web/app.js"], set()
    while pending:
        url = pending.pop()
        if url in seen:
            continue
        seen.add(url)
        source = httpx.get(agent.url + url).content
        assert import_map["integrity"][url] == sri(source), url
        for target in re.findall(
            rb'(?:^|\n)\s*(?:import|export)\b[^;"\']*?from\s*["\']([^"\']+)["\']', source
        ):
            target = target.decode()
            resolved = import_map["imports"].get(target) or (
                target if target.startswith("/") else url.rsplit("/", 1)[0] + "/" + target.removeprefix("./")
            )
            pending.append(resolved)
    assert {"/web/viewer.js", "/web/vendor/three-0.187.0/three.core.js"} <= seen
    inline = re.search(r'<script type="importmap">(.*?)</script>', html, re.DOTALL).group(1)
    digest = base64.b64encode(hashlib.sha256(inline.encode()).digest()).decode()
    assert f"'sha256-{digest}'" in httpx.get(agent.url + "/").headers["content-security-policy"]


@pytest.mark.parametrize("encoding", ["gzip", "br", "zstd"])
def test_the_page_and_the_points_are_compressed(agent, scene_id, encoding):
    paths = ["/", "/web/app.js", "/web/style.css", "/web/vendor/three-0.187.0/three.core.js"]
    paths.append(f"/v1/scenes/{scene_id}/points?max_points=20000")
    for path in paths:
        with httpx.stream("GET", agent.url + path, headers={"Accept-Encoding": encoding}) as response:
            wire = b"".join(response.iter_raw())
            assert response.headers.get("content-encoding") == encoding, path
        plain = httpx.get(agent.url + path, headers={"Accept-Encoding": "identity"})
        assert "content-encoding" not in plain.headers
        assert (
            httpx.Response(200, headers={"content-encoding": encoding}, content=wire).content == plain.content
        )
        assert len(wire) < 0.9 * len(plain.content), (path, len(wire), len(plain.content))


def test_a_first_visit_moves_at_least_three_times_fewer_bytes_compressed(agent):
    """What the page loads on a first visit (its tags and every module they import), in bytes on
    the wire without compression and with gzip (what every browser accepts); bench/web_bytes.py
    measures the same in the real browser."""
    html = httpx.get(agent.url + "/").text
    urls = ["/", *re.findall(r'(?:src|href)="(/web/[^"]+)"', html)]
    urls += [
        url
        for url in json.loads(re.search(r'importmap">(.*?)</script>', html, re.DOTALL).group(1))["integrity"]
    ]
    urls = sorted(set(urls) - {"/web/vendor/highlight-11.11.1/highlight.min.js"}) + [
        "/web/vendor/highlight-11.11.1/highlight.min.js"
    ]

    def wire_bytes(encoding: str) -> int:
        total = 0
        for url in urls:
            with httpx.stream("GET", agent.url + url, headers={"Accept-Encoding": encoding}) as response:
                total += sum(len(chunk) for chunk in response.iter_raw())
        return total

    plain, gzipped = wire_bytes("identity"), wire_bytes("gzip")
    assert plain > 2_000_000 and plain / gzipped >= 3.0, (plain, gzipped)


def test_stage_events_arrive_live_through_compression(agent, llm, scene_id):
    """The code model answers after 2 s: the events before it must not wait for it in a buffer."""
    for encoding in ("gzip", "br", "zstd"):
        llm.reset()
        llm.script([{"text": MOTION_PROGRAM, "delay_s": 2.0}], model="coder")
        arrivals = []
        started = time.monotonic()
        headers = {**SSE, "Accept-Encoding": encoding}
        body = {"question": QUESTION, "scene_id": scene_id, "backbone": "posed-rgbd"}
        with httpx.stream(
            "POST", agent.url + "/v1/solve", json=body, headers=headers, timeout=60
        ) as response:
            assert response.headers["content-encoding"] == encoding
            for line in response.iter_lines():  # decoded as the compressed bytes arrive
                if line.startswith("data: "):
                    arrivals.append((time.monotonic() - started, json.loads(line.removeprefix("data: "))))
        program_started = next(
            t for t, e in arrivals if e.get("stage") == "program" and e["state"] == "started"
        )
        result = next(t for t, e in arrivals if e["type"] == "result")
        assert result - program_started >= 1.5, (encoding, arrivals)


def _sandbox_workers(agent) -> list[int]:
    found = []
    for child in psutil.Process(agent.process.pid).children(recursive=True):
        try:
            if "services.agent.sandbox.worker" in " ".join(child.cmdline()) and child.status() != "zombie":
                found.append(child.pid)
        except psutil.NoSuchProcess:
            continue
    return found


def test_a_plain_solve_whose_client_leaves_stops_its_sandbox(agent, llm, scene_id):
    llm.reset()
    llm.script([ENDLESS_PROGRAM], model="coder")
    body = {"question": QUESTION, "scene_id": scene_id, "backbone": "posed-rgbd"}
    with pytest.raises(httpx.ReadTimeout):  # the client gives up and closes its connection
        httpx.post(agent.url + "/v1/solve", json=body, timeout=httpx.Timeout(60, read=4.0))
    deadline = time.monotonic() + 5
    while _sandbox_workers(agent):
        assert time.monotonic() < deadline, "the sandbox still runs 5 s after the client left"
        time.sleep(0.05)
    assert "solve cancelled: the client went away" in agent.log()


def test_the_examples_and_their_photos(agent):
    examples = httpx.get(agent.url + "/v1/examples").json()["examples"]
    names = [example["name"] for example in examples]
    assert names[0] == "living_room" and {"corner_turn", "step_back", "temple_ring"} <= set(names)
    for example in examples:
        spec = json.loads((REPO_ROOT / "examples" / example["name"] / "example.json").read_text())
        assert len(example["images"]) == len(spec["images"]) == 3
        photo = httpx.get(agent.url + example["images"][0])
        assert photo.status_code == 200 and photo.content.startswith(b"\x89PNG")
        thumbnail = httpx.get(agent.url + example["thumbnail"])
        assert thumbnail.headers["content-type"] == "image/jpeg" and len(thumbnail.content) < 20_000
        assert {q["free_form"] for q in example["questions"]} == {True, False}
    temple = next(example for example in examples if example["name"] == "temple_ring")
    assert temple["source"] == "real" and "Seitz" in temple["citation"]
    assert httpx.get(agent.url + "/v1/examples/temple_ring/images/..%2Fexample.json").status_code == 404
    assert httpx.get(agent.url + "/v1/examples/nothing/images/view_1.png").status_code == 404


def test_the_reconstruction_downloads_as_ply_and_glb(agent, recon, scene_id):
    import trimesh

    from shared.wire.client import ReconClient

    with ReconClient(recon.url) as client:
        stored = client.reconstruction(scene_id, "posed-rgbd")
    path = f"/v1/scenes/{scene_id}/reconstruction"
    ply = httpx.get(agent.url + path, params={"format": "ply", "backbone": "posed-rgbd"})
    assert ply.status_code == 200 and ply.headers["content-type"] == "application/x-ply"
    assert ply.headers["content-disposition"] == f'attachment; filename="{scene_id}.ply"'
    assert ply.content == stored.to_ply() and int(ply.headers["content-length"]) == len(ply.content)
    glb = httpx.get(agent.url + path, params={"format": "glb", "backbone": "posed-rgbd"})
    assert glb.status_code == 200 and glb.headers["content-type"] == "model/gltf-binary"
    cloud = next(
        iter(trimesh.load(trimesh.util.wrap_as_stream(glb.content), file_type="glb").geometry.values())
    )
    assert len(cloud.vertices) == stored.num_points
    assert (cloud.colors[:, :3] == stored.colors).all()
    assert httpx.get(agent.url + path, params={"format": "obj"}).status_code == 422
    assert httpx.get(agent.url + f"/v1/scenes/{'0' * 24}/reconstruction").status_code == 404
