"""Tenants over HTTP: each key belongs to one; a tenant's scenes are invisible to the others.

One recon (keys of tenants alpha and beta, a plain key of the default tenant, and the agent's
service key) and one agent (keys of alpha and beta) as real processes; scene ids differ per tenant,
the same upload is one scene within a tenant, and beta can neither read, render nor reconstruct
alpha's scene by its id, directly or through the agent.
"""

from __future__ import annotations

import httpx
import pytest

from services.recon.scene_store import SceneInput
from services.recon.tenants import SceneIds, load_or_create_secret
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
            "motion": _status(lambda: beta.camera_motion(scene, [(0, 1)])),
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
