"""describe_camera_motion for any pair of views: recon endpoint, sandbox tool, paper-style API."""

from __future__ import annotations

import httpx
import numpy as np
import pytest

from services.agent.recon_tools import ReconToolProvider
from services.agent.sandbox.runner import run_program
from shared.geometry.camera_motion import describe_pairs
from shared.local.services import running_service
from shared.wire.api import Reconstruction, SpatialToolkit
from shared.wire.client import ReconClient
from tests.support.scenes import orbit_views
from tests.support.stack import recon_env
from tests.test_sandbox import LIMITS

VIEWS = orbit_views(seed=3, num_views=3, step_deg=25.0)


@pytest.fixture(scope="module")
def recon(tmp_path_factory, redis_url):
    env = recon_env(tmp_path_factory.mktemp("recon"), redis_url)
    with running_service("services.recon.app:create_app", env) as service:
        yield service


@pytest.fixture(scope="module")
def scene_id(recon) -> str:
    with ReconClient(recon.url) as client:
        return client.upload_scene(
            VIEWS.pngs(), depths=VIEWS.depths, extrinsics=VIEWS.extrinsics, intrinsics=VIEWS.intrinsics
        ).scene_id


def test_the_endpoint_describes_a_non_consecutive_pair(recon, scene_id) -> None:
    with ReconClient(recon.url) as client:
        one = client.camera_motion(scene_id, from_view=1, to_view=3)
        same = client.camera_motion(scene_id, pairs=[(1, 3)])  # 1-based, as from_view/to_view
        back = client.camera_motion(scene_id, from_view=3, to_view=1)
        consecutive = client.camera_motion(scene_id)
    assert [(m.from_view, m.to_view) for m in one.motions] == [(1, 3)]
    assert one.text.startswith("From view 1 to view 3, in view 1's image axes, ") and one.text == same.text
    assert back.text.startswith("From view 3 to view 1, in view 3's image axes, ")
    # The exact cameras' own description of that pair (shared/geometry), not a chain of two.
    exact = describe_pairs(np.asarray(VIEWS.extrinsics), [None] * 3, pairs=[(0, 2)])[0]
    assert (one.motions[0].direction, one.motions[0].turn) == (exact.direction, exact.turn)
    assert [(m.from_view, m.to_view) for m in consecutive.motions] == [(1, 2), (2, 3)]


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ({"from_view": 1}, "go together"),
        ({"from_view": 2, "to_view": 2}, "different"),
        ({"from_view": 1, "to_view": 2, "pairs": [[1, 2]]}, "not both"),
        ({"from_view": 0, "to_view": 2}, "greater than or equal to 1"),
    ],
)
def test_the_endpoint_refuses_malformed_pairs(recon, scene_id, body, message) -> None:
    response = httpx.post(f"{recon.url}/v1/camera-motion", json={"scene_id": scene_id, **body}, timeout=30)
    assert response.status_code == 422 and message in response.text


def test_a_view_out_of_range_is_a_4xx(recon, scene_id) -> None:
    response = httpx.post(
        f"{recon.url}/v1/camera-motion", json={"scene_id": scene_id, "from_view": 1, "to_view": 4}, timeout=30
    )
    assert response.status_code == 422 and "view 4 does not exist: the scene has views 1..3" in response.text


def test_the_sandbox_tool_and_the_python_api_name_any_pair(recon, scene_id) -> None:
    with ReconClient(recon.url) as client:
        tools = ReconToolProvider(client, scene_id, None, VIEWS.pngs())
        result = run_program(
            "def program(input_scene):\n"
            "    recon = pySpatial.reconstruct(input_scene)\n"
            "    return pySpatial.describe_camera_motion(recon, from_view=1, to_view=3)\n",
            "How did I move from image 1 to image 3?", 3, tools, LIMITS,
        )  # fmt: skip
        expected = client.camera_motion(scene_id, from_view=1, to_view=3).text
        wrong = run_program(
            "def program(input_scene):\n"
            "    recon = pySpatial.reconstruct(input_scene)\n"
            "    return pySpatial.describe_camera_motion(recon, 0, 2)\n",
            "How did I move from image 1 to image 3?", 3, tools, LIMITS,
        )  # fmt: skip
    assert result.ok, result.error
    assert result.clue_text == expected
    assert not wrong.ok and "views are numbered 1..3" in wrong.error
    api = SpatialToolkit(recon.url)
    handle = Reconstruction(api.client, api.client.reconstruct(scene_id))
    assert api.describe_camera_motion(handle, 1, 3) == expected
    assert api.describe_camera_motion(handle).count("\n") == 1  # the consecutive form: two sentences
    api.client.close()
