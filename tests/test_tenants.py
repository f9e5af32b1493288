"""Tenants over HTTP: each key belongs to one; a tenant's scenes are invisible to the others.

One recon (keys of tenants alpha and beta, a plain key of the default tenant, and the agent's
service key) and one agent (keys of alpha and beta) as real processes; scene ids differ per tenant,
the same upload is one scene within a tenant, and beta can neither read, render nor reconstruct
alpha's scene by its id, directly or through the agent. Every route of both OpenAPI documents that
takes a `scene_id` (path, query, JSON body or form field) is walked: alpha's call reaches the scene,
beta's is a 404.
"""

from __future__ import annotations

import json

import httpx
import numpy as np
import pytest

from services.recon.scene_store import SceneInput
from services.recon.tenants import SceneIds, load_or_create_secret
from shared.synthetic.two_rooms import generate_two_rooms
from shared.wire.access import DEFAULT_TENANT, SERVICE_TENANT, parse_tenant_keys
from shared.wire.client import AgentClient, ReconClient, ServiceError
from shared.wire.settings import AccessSettings
from tests.support.processes import running_service
from tests.support.scenes import orbit_views
from tests.test_agent_service import motion_question
from tests.test_recon_runtime import jittered

RECON_APP = "services.recon.app:create_app"
AGENT_APP = "services.agent.app:create_app"
ALPHA, BETA, PLAIN, SERVICE = "alpha-key-1", "beta-key-1", "plain-key-1", "agent-service-key"
RECON_KEYS = f"alpha:{ALPHA},beta:{BETA},{PLAIN},*:{SERVICE}"


@pytest.fixture(scope="module")
def views():
    return orbit_views(seed=5, num_views=3)


@pytest.fixture(scope="module")
def stack(tmp_path_factory):
    data = tmp_path_factory.mktemp("tenants")
    recon_env = {
        "PYSPATIAL_DATA_DIR": str(data / "data"),
        "PYSPATIAL_STORE_DIR": str(data / "store"),
        "PYSPATIAL_API_KEYS": RECON_KEYS,
        "PYSPATIAL_BACKBONE": "classical",
    }
    with running_service(RECON_APP, recon_env) as recon:
        agent_env = {
            "PYSPATIAL_RECON_URL": recon.url,
            "PYSPATIAL_RECON_API_KEY": f"*:{SERVICE}",  # the entry as recon lists it: the agent sends the key
            "PYSPATIAL_API_KEYS": "alpha:agent-alpha,beta:agent-beta",
        }
        with running_service(AGENT_APP, agent_env) as agent:
            yield recon, agent


def _status(call) -> int:
    try:
        call()
    except ServiceError as error:
        return error.status_code
    return 200


def test_recon_keeps_each_tenants_scenes_to_itself(stack, views):
    recon, _ = stack
    upload = jittered(views.images, 700)
    with (
        ReconClient(recon.url, api_key=ALPHA) as alpha,
        ReconClient(recon.url, api_key=BETA) as beta,
        ReconClient(recon.url, api_key=PLAIN) as plain,
    ):
        first = alpha.upload_scene(upload)
        again = alpha.upload_scene(upload)
        theirs = beta.upload_scene(upload)
        default = plain.upload_scene(upload)
        assert first.created and not again.created and again.scene_id == first.scene_id  # dedup within
        assert len({first.scene_id, theirs.scene_id, default.scene_id}) == 3  # ids per tenant
        scene = first.scene_id
        assert len(alpha.reconstruct(scene).cameras) == 3
        refusals = {
            "info": _status(lambda: beta.scene_info(scene)),
            "image": _status(lambda: beta.scene_image(scene, 0)),
            "reconstruct": _status(lambda: beta.reconstruct(scene)),
            "download": _status(lambda: beta.reconstruction(scene)),
            "points": _status(lambda: beta.points(scene)),
            "render": _status(lambda: beta.render(scene, views.extrinsics[0], 32, 32)),
            "motion": _status(lambda: beta.camera_motion(scene, [(1, 2)])),
            "default tenant": _status(lambda: plain.scene_info(scene)),
        }
        assert refusals == dict.fromkeys(refusals, 404)
        unknown = "0" * 24
        with pytest.raises(ServiceError) as missing:
            beta.scene_info(unknown)
        with pytest.raises(ServiceError) as foreign:
            beta.scene_info(scene)
        assert str(missing.value).replace(unknown, scene) == str(foreign.value)  # no oracle
        assert alpha.scene_info(scene).num_images == 3


def test_the_service_key_acts_only_for_the_tenant_it_names(stack, views):
    recon, _ = stack
    with ReconClient(recon.url, api_key=ALPHA) as alpha, ReconClient(recon.url, api_key=SERVICE) as service:
        scene = alpha.upload_scene(jittered(views.images, 701)).scene_id
        assert service.for_tenant("alpha").scene_info(scene).num_images == 3
        assert _status(lambda: service.for_tenant("beta").scene_info(scene)) == 404
        assert _status(lambda: service.scene_info(scene)) == 404  # no header: the default tenant
        # a tenant key means its own tenant: naming another is refused (an agent given a tenant's
        # key instead of the service key fails loudly rather than mixing tenants)
        with ReconClient(recon.url, api_key=BETA) as beta, ReconClient(recon.url, api_key=PLAIN) as plain:
            assert _status(lambda: beta.for_tenant("alpha").scene_info(scene)) == 403
            assert _status(lambda: plain.for_tenant("alpha").scene_info(scene)) == 403
            assert _status(lambda: alpha.for_tenant("alpha").scene_info(scene)) == 200
        headers = {"Authorization": f"Bearer {SERVICE}", "X-PySpatial-Tenant": "../etc"}
        assert httpx.get(f"{recon.url}/v1/scenes/{scene}", headers=headers).status_code == 400


def test_through_the_agent_beta_cannot_use_alphas_scene(stack, views):
    _, agent = stack
    question, truth = motion_question(views)
    with (
        AgentClient(agent.url, api_key="agent-alpha", timeout=120) as alpha,
        AgentClient(agent.url, api_key="agent-beta", timeout=120) as beta,
    ):
        # Photos as a camera writes them (focal length in EXIF): without it the motion of this pair
        # differs over the focal lengths two photos allow, and the honest answer is "cannot say".
        solved = alpha.solve(question, images=jittered(views.images, 702, views.intrinsics))
        assert solved.answer == truth
        scene = solved.scene_id
        assert alpha.solve(question, scene_id=scene).answer == truth
        assert _status(lambda: beta.solve(question, scene_id=scene)) == 404
        headers = {"Authorization": "Bearer agent-beta"}
        for path in (f"/v1/scenes/{scene}/points", f"/v1/scenes/{scene}/reconstruction?format=ply"):
            assert httpx.get(agent.url + path, headers=headers, timeout=60).status_code == 404, path
        alpha_headers = {"Authorization": "Bearer agent-alpha"}
        assert httpx.get(f"{agent.url}/v1/scenes/{scene}/points", headers=alpha_headers).status_code == 200


@pytest.fixture(scope="module")
def rooms():
    two = generate_two_rooms(2, "reachable")
    return two, two.render()


def _posed_upload(two, views) -> dict:
    return {
        "images": [v.rgb for v in views],
        "depths": [v.depth for v in views],
        "extrinsics": two.extrinsics,
        "intrinsics": [two.intrinsic] * len(views),
    }


def test_a_route_by_scene_id_is_the_tenants_and_as_uploaded(stack, rooms):
    """Recon's default here is classical: a posed scene by id must still be planned on posed-rgbd."""
    _, agent = stack
    two, views = rooms
    goal = {"point_world": two.goal.tolist()}
    with (
        AgentClient(agent.url, api_key="agent-alpha", timeout=120) as alpha,
        AgentClient(agent.url, api_key="agent-beta", timeout=120) as beta,
    ):
        uploaded = alpha.route(goal, start_view=1, **_posed_upload(two, views))
        by_id = alpha.route(goal, scene_id=uploaded.scene_id, start_view=1)
        assert uploaded.reachable and uploaded.backbone == "posed-rgbd"
        assert by_id.backbone == "posed-rgbd" and by_id.units == uploaded.units
        assert [s.model_dump() for s in by_id.steps] == [s.model_dump() for s in uploaded.steps]
        assert by_id.length == uploaded.length
        assert _status(lambda: beta.route(goal, scene_id=uploaded.scene_id, start_view=1)) == 404
        try:  # a backbone the request names wins (here classical, which may not place these views)
            assert alpha.route(goal, scene_id=uploaded.scene_id, backbone="classical").backbone == "classical"
        except ServiceError as error:
            assert error.status_code == 422 and "backbone classical" in str(error)


# ---- every route that takes a scene_id, from the OpenAPI documents ---------------------------------


def _schema_properties(schema: dict, components: dict) -> set[str]:
    if "$ref" in schema:
        schema = components[schema["$ref"].rsplit("/", 1)[-1]]
    names = set(schema.get("properties", {}))
    for key in ("anyOf", "oneOf", "allOf"):
        for part in schema.get(key, []):
            names |= _schema_properties(part, components)
    return names


def scene_id_routes(document: dict) -> set[tuple[str, str, str]]:
    """(METHOD, path, where) for every way a route takes a scene_id: path, query or a body type."""
    components = document.get("components", {}).get("schemas", {})
    found = set()
    for path, item in document["paths"].items():
        for method, operation in item.items():
            for parameter in operation.get("parameters", []):
                if parameter["name"] == "scene_id":
                    found.add((method.upper(), path, parameter["in"]))
            for media, content in operation.get("requestBody", {}).get("content", {}).items():
                if "scene_id" in _schema_properties(content.get("schema", {}), components):
                    found.add((method.upper(), path, media))
    return found


def _form(**fields) -> dict:
    """Form fields as multipart parts (httpx sends multipart only with `files`; no filename: text)."""
    return {"files": {name: (None, value) for name, value in fields.items()}}


def _recon_requests(scene: str, pose: list) -> dict:
    return {
        ("GET", "/v1/scenes/{scene_id}", "path"): ("GET", f"/v1/scenes/{scene}", {}),
        ("GET", "/v1/scenes/{scene_id}/images/{index}", "path"): ("GET", f"/v1/scenes/{scene}/images/0", {}),
        ("GET", "/v1/scenes/{scene_id}/points", "path"): ("GET", f"/v1/scenes/{scene}/points", {}),
        ("POST", "/v1/scenes/{scene_id}/reconstruct", "path"): (
            "POST",
            f"/v1/scenes/{scene}/reconstruct",
            {},
        ),
        ("GET", "/v1/scenes/{scene_id}/reconstruction", "path"): (
            "GET",
            f"/v1/scenes/{scene}/reconstruction",
            {},
        ),
        ("POST", "/v1/render", "application/json"): (
            "POST",
            "/v1/render",
            {"json": {"scene_id": scene, "extrinsic": pose, "width": 32, "height": 32}},
        ),
        ("POST", "/v1/camera-motion", "application/json"): (
            "POST",
            "/v1/camera-motion",
            {"json": {"scene_id": scene}},
        ),
    }


def _agent_requests(scene: str, goal: list) -> dict:
    route = {"scene_id": scene, "start_view": 1, "goal": {"point_world": goal}}
    question = "How did the camera move from view 1 to view 2?"
    return {
        ("GET", "/v1/scenes/{scene_id}/points", "path"): ("GET", f"/v1/scenes/{scene}/points", {}),
        ("GET", "/v1/scenes/{scene_id}/reconstruction", "path"): (
            "GET",
            f"/v1/scenes/{scene}/reconstruction?format=ply",
            {},
        ),
        ("POST", "/v1/route", "application/json"): ("POST", "/v1/route", {"json": route}),
        ("POST", "/v1/route", "multipart/form-data"): (
            "POST",
            "/v1/route",
            _form(scene_id=scene, start_view="1", goal=json.dumps(route["goal"])),
        ),
        ("POST", "/v1/solve", "application/json"): (
            "POST",
            "/v1/solve",
            {"json": {"question": question, "scene_id": scene}},
        ),
        ("POST", "/v1/solve", "multipart/form-data"): (
            "POST",
            "/v1/solve",
            _form(question=question, scene_id=scene),
        ),
    }


def _walk(url: str, requests: dict, owner: str, other: str) -> None:
    document = httpx.get(f"{url}/openapi.json", timeout=30).json()
    routes = scene_id_routes(document)
    assert routes == set(requests), "a route takes a scene_id that this test does not call (or the reverse)"
    for key, (method, path, arguments) in requests.items():
        with httpx.Client(base_url=url, timeout=180) as http:
            mine = http.request(method, path, headers={"Authorization": f"Bearer {owner}"}, **arguments)
            theirs = http.request(method, path, headers={"Authorization": f"Bearer {other}"}, **arguments)
        assert mine.status_code != 404 and mine.status_code < 500, (key, mine.text[:300])
        assert theirs.status_code == 404, (key, theirs.status_code, theirs.text[:300])


def test_every_route_that_takes_a_scene_id_refuses_another_tenant(stack, rooms):
    recon, agent = stack
    two, views = rooms
    with ReconClient(recon.url, api_key=ALPHA, timeout=120) as alpha:
        scene = alpha.upload_scene(
            [v.rgb for v in views],
            depths=[v.depth for v in views],
            extrinsics=two.extrinsics,
            intrinsics=np.stack([two.intrinsic] * len(views)),
        ).scene_id
    _walk(recon.url, _recon_requests(scene, two.extrinsics[0].tolist()), ALPHA, BETA)
    _walk(agent.url, _agent_requests(scene, two.goal.tolist()), "agent-alpha", "agent-beta")


# ---- without processes ----------------------------------------------------------------------------


def test_keys_name_their_tenants_and_plain_keys_stay_the_defaults():
    keys = parse_tenant_keys(AccessSettings(api_keys=f"{RECON_KEYS}, odd:colon:key ,bad name:k"))
    assert keys[ALPHA.encode()] == "alpha" and keys[BETA.encode()] == "beta"
    assert keys[PLAIN.encode()] == DEFAULT_TENANT and keys[SERVICE.encode()] == SERVICE_TENANT
    assert keys[b"colon:key"] == "odd"  # the first colon splits
    assert keys[b"bad name:k"] == DEFAULT_TENANT  # no tenant name before the colon: a plain key


def test_scene_ids_are_stable_per_tenant_and_the_secret_is_created_once(tmp_path):
    secret = load_or_create_secret(tmp_path)
    assert load_or_create_secret(tmp_path) == secret and len(secret) == 32
    content = SceneInput(image_files=[b"one", b"two"]).content_id()
    ids = SceneIds(secret)
    assert ids.scene_id(DEFAULT_TENANT, content) == content  # ids from before tenants still hold
    alpha = ids.scene_id("alpha", content)
    assert alpha == SceneIds(secret).scene_id("alpha", content) != ids.scene_id("beta", content)
    assert SceneIds(b"another secret").scene_id("alpha", content) != alpha
