"""The sandbox runs ordinary programs correctly, against a real local ToolProvider.

The provider holds three real camera poses and a small coloured point scene; it renders views by
projecting the points with the requested pose (real numpy numerics, real PNGs via Pillow) and
describes the motion between views from the poses. Programs run in the real sandbox process.
"""

from __future__ import annotations

import ast
import io
import json
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from PIL import Image

from services.agent.sandbox import (
    ProgramRejected,
    SandboxLimits,
    numpy_surface,
    run_program,
    validate_program,
)
from shared.geometry import poses

LIMITS = SandboxLimits(cpu_seconds=10, wall_seconds=20, memory_mb=1024)


def level_camera(center: list[float], yaw_right_deg: float) -> np.ndarray:
    """A level camera (world y down, like OpenCV) at `center`, turned right by `yaw_right_deg`."""
    at_origin = np.hstack([np.eye(3), np.zeros((3, 1))])
    turned = poses.rotate_right(at_origin, yaw_right_deg, up=np.array([0.0, -1.0, 0.0]))
    rotation = turned[:3, :3]
    return np.hstack([rotation, (-rotation @ np.asarray(center, dtype=float))[:, None]])


class PointSceneTools:
    """A ToolProvider over a tiny coloured point scene, with real projection and PNG encoding."""

    def __init__(self, fail_rendering: bool = False, unregistered: int | None = None) -> None:
        self.extrinsics = [
            level_camera([0.0, 0.0, 0.0], 0.0),
            level_camera([0.5, 0.0, 0.0], 0.0),
            level_camera([0.5, 0.0, 0.0], 30.0),
        ]
        self.registered = [index != unregistered for index in range(3)]
        self.image_size = (48, 32)
        self.intrinsic = np.array([[40.0, 0.0, 24.0], [0.0, 40.0, 16.0], [0.0, 0.0, 1.0]])
        grid = np.stack(np.meshgrid(np.linspace(-2, 2, 9), np.linspace(-1, 1, 5)), axis=-1).reshape(-1, 2)
        self.points = np.column_stack([grid, np.full(len(grid), 3.0)])  # a wall 3 units ahead
        self.colors = np.where(grid[:, :1] < 0, [[220, 40, 40]], [[40, 40, 220]]).astype(np.uint8)
        self.fail_rendering = fail_rendering
        self.rendered_poses: list[np.ndarray] = []

    def render(self, extrinsic: np.ndarray, width: int, height: int) -> bytes:
        scale = np.diag([width / self.image_size[0], height / self.image_size[1], 1.0])
        camera = (np.asarray(extrinsic)[:3, :3] @ self.points.T).T + np.asarray(extrinsic)[:3, 3]
        pixels = np.zeros((height, width, 3), dtype=np.uint8)
        ahead = camera[:, 2] > 1e-6
        projected = (scale @ self.intrinsic @ camera[ahead].T).T
        uv = np.round(projected[:, :2] / projected[:, 2:]).astype(int)
        for (u, v), color in zip(uv, self.colors[ahead], strict=True):
            if 0 <= u < width and 0 <= v < height:
                pixels[max(v - 1, 0) : v + 2, max(u - 1, 0) : u + 2] = color
        buffer = io.BytesIO()
        Image.fromarray(pixels).save(buffer, format="PNG")
        return buffer.getvalue()

    def reconstruct(self) -> dict:
        nan_pose = np.full((3, 4), np.nan)
        return {
            "extrinsics": [
                (pose if ok else nan_pose).tolist()
                for pose, ok in zip(self.extrinsics, self.registered, strict=True)
            ],
            "intrinsics": [self.intrinsic.tolist()] * 3,
            "image_sizes": [list(self.image_size)] * 3,
            "registered": list(self.registered),
        }

    def describe_camera_motion(self) -> list[str]:
        sentences = []
        for index in range(len(self.extrinsics) - 1):
            first, second = self.extrinsics[index], self.extrinsics[index + 1]
            offset = first[:3, :3] @ (poses.camera_center(second) - poses.camera_center(first))
            side = "right" if offset[0] > 0 else "left"
            forward = second[:3, :3][2] @ first[:3, :3][0]  # >0: the new view looks to the right
            turn = np.degrees(np.arcsin(np.clip(forward, -1, 1)))
            sentences.append(
                f"From image {index + 1} to image {index + 2} the camera moved {side} by "
                f"{np.linalg.norm(offset):.2f} and turned right by {turn:.0f} degrees."
            )
        return sentences

    def synthesize_novel_view(self, extrinsic: list[list[float]], width: int, height: int) -> bytes:
        if self.fail_rendering:
            raise RuntimeError("renderer exploded")
        self.rendered_poses.append(np.asarray(extrinsic))
        return self.render(np.asarray(extrinsic), width, height)

    def input_image(self, index: int) -> bytes:
        return self.render(self.extrinsics[index], *self.image_size)


def run(source: str, tools: PointSceneTools | None = None, limits: SandboxLimits = LIMITS, images: int = 3):
    return run_program(source, "Which way did I turn?", images, tools or PointSceneTools(), limits)


def test_camera_motion_text_is_the_providers_sentences() -> None:
    tools = PointSceneTools()
    result = run(
        "def program(input_scene):\n"
        "    recon = pySpatial.reconstruct(input_scene)\n"
        "    return pySpatial.describe_camera_motion(recon)\n",
        tools,
    )
    assert result.ok, result.error
    assert result.clue_text == "\n".join(tools.describe_camera_motion())
    assert "turned right by 30 degrees" in result.clue_text
    assert result.clue_images == []
    assert result.tool_calls == ["reconstruct", "describe_camera_motion"]


def test_pose_tools_in_the_sandbox_match_shared_poses_about_the_scene_up() -> None:
    tools = PointSceneTools()
    result = run(
        "def program(input_scene):\n"
        "    recon = pySpatial.reconstruct(input_scene)\n"
        "    pose = recon.extrinsics[2]\n"
        "    return {\n"
        "        'left': pySpatial.rotate_left(pose, angle=90),\n"
        "        'right': pySpatial.rotate_right(pose),\n"
        "        'forward': pySpatial.move_forward(pose, distance=0.5),\n"
        "        'back': pySpatial.move_backward(pose),\n"
        "        'around': pySpatial.turn_around(pose),\n"
        "        'views': recon.num_views,\n"
        "    }\n",
        tools,
    )
    assert result.ok, result.error
    lines = dict(line.split(": ", 1) for line in result.clue_text.splitlines())
    up = poses.estimate_up_axis(np.stack(tools.extrinsics))
    pose = tools.extrinsics[2]
    expected = {
        "left": poses.rotate_left(pose, 90, up=up),
        "right": poses.rotate_right(pose, 45, up=up),
        "forward": poses.move_forward(pose, 0.5, up=up),
        "back": poses.move_backward(pose, 0.3, up=up),
        "around": poses.turn_around(pose, up=up),
    }
    for name, matrix in expected.items():  # programs get 4x4 extrinsics; tools keep the shape given
        returned = np.array(json.loads(lines[name]))
        assert returned.shape == (4, 4), name
        np.testing.assert_allclose(returned[:3], matrix, atol=1e-9, err_msg=name)
    assert lines["views"] == "3"


def test_novel_view_is_the_png_the_provider_rendered_for_the_moved_pose() -> None:
    tools = PointSceneTools()
    result = run(
        "def program(input_scene):\n"
        "    recon = pySpatial.reconstruct(input_scene)\n"
        "    moved = pySpatial.move_forward(recon.extrinsics[0], distance=1.0)\n"
        "    view = pySpatial.synthesize_novel_view(recon, moved, width=64, height=40)\n"
        "    return [view, 'size %dx%d' % (view.width, view.height)]\n",
        tools,
    )
    assert result.ok, result.error
    expected_pose = poses.move_forward(
        tools.extrinsics[0], 1.0, up=poses.estimate_up_axis(np.stack(tools.extrinsics))
    )
    np.testing.assert_allclose(tools.rendered_poses[0], expected_pose, atol=1e-9)
    assert result.clue_images == [tools.render(expected_pose, 64, 40)]
    assert result.clue_text == "<image 1>\nsize 64x40"
    rendered = np.asarray(Image.open(io.BytesIO(result.clue_images[0])))
    assert rendered.shape == (40, 64, 3) and rendered.any()  # closer to the wall: dots are visible


def test_input_images_are_returned_as_png_with_their_sizes() -> None:
    tools = PointSceneTools()
    result = run(
        "def program(input_scene):\n"
        "    first = input_scene.images[0]\n"
        "    return [first, input_scene.images[2], str(first.width) + 'x' + str(first.height)]\n",
        tools,
    )
    assert result.ok, result.error
    assert result.clue_images == [tools.input_image(0), tools.input_image(2)]
    assert result.clue_text == "<image 1>\n<image 2>\n48x32"


def test_a_single_image_has_no_text_and_the_question_is_visible() -> None:
    result = run(
        "def program(input_scene):\n"
        "    assert input_scene.question.startswith('Which way')\n"
        "    return input_scene.images[1]\n"
    )
    assert result.ok, result.error
    assert result.clue_text is None and len(result.clue_images) == 1


def test_prints_are_captured_and_format_strings_work() -> None:
    result = run(
        "import numpy as np\n"
        "import math\n"
        "def program(input_scene):\n"
        "    angle = math.degrees(np.arctan2(1.0, 1.0))\n"
        "    print('angle', angle)\n"
        "    return '{:.1f} degrees, {name}'.format(angle, name='ok') + f' {angle:.0f}'\n"
    )
    assert result.ok, result.error
    assert result.clue_text == "45.0 degrees, ok 45"
    assert result.stdout == "angle 45.0\n"


def test_helpers_constants_and_numpy_arrays() -> None:
    result = run(
        "STEP = np.pi / 4\n"
        "NAMES = ('a', 'b')\n"
        "def twice(x):\n"
        "    return 2 * x\n"
        "def program(input_scene):\n"
        "    values = sorted([twice(STEP), STEP], key=lambda v: -v)\n"
        "    return {'values': np.round(np.array(values), 3), 'names': list(NAMES), 'eye': np.eye(2)}\n"
    )
    assert result.ok, result.error
    assert result.clue_text.splitlines() == [
        "values: [1.571, 0.785]",
        'names: ["a", "b"]',
        "eye: [[1.0, 0.0], [0.0, 1.0]]",
    ]


def test_restricted_numpy_covers_pose_arithmetic() -> None:
    result = run(
        "def program(input_scene):\n"
        "    recon = pySpatial.reconstruct(input_scene)\n"
        "    e = recon.extrinsics[2]\n"
        "    R, t = e[:3, :3], e[:3, 3]\n"  # extrinsics are 4x4 [[R, t], [0, 0, 0, 1]]
        "    center = -R.T @ t\n"
        "    forward = R[2]\n"
        "    yaw = np.degrees(np.arctan2(forward[0], forward[2]))\n"
        "    checks = [np.allclose(np.linalg.inv(R), R.T), abs(np.linalg.det(R) - 1) < 1e-9,\n"
        "              float(np.median(np.array([3.0, 1.0, 2.0]))) == 2.0, np.linalg.norm(center) > 0,\n"
        "              np.cross([1, 0, 0], [0, 1, 0]).tolist() == [0, 0, 1], np.isclose(np.cos(0), 1)]\n"
        "    level = bool(np.allclose(recon.up, [0, -1, 0]))\n"
        "    return [round(float(yaw)), all(checks), level, str(R.round(2))]\n"
    )
    assert result.ok, result.error
    assert result.clue_text.splitlines()[:3] == ["30", "True", "True"]
    assert result.clue_text.splitlines()[3].startswith("[[ 0.87  0.   -0.5 ]")


# Every call a program may reasonably make on the numpy stand-in, with its expected value. Numpy
# initialises some of these lazily through imports, which the sandbox refuses once a program runs.
NUMPY_CALLS = {
    "np.arange(3).tolist()": [0, 1, 2],
    "np.linspace(0, 1, 3).tolist()": [0.0, 0.5, 1.0],
    "np.where(a > 1.5, 1, 0).tolist()": [[1, 0], [0, 1]],
    "np.sort(a).tolist()": [[1.0, 2.0], [1.0, 3.0]],
    "np.argsort(a).tolist()": [[1, 0], [0, 1]],
    "float(np.median(a))": 1.5,
    "round(float(np.std(a)), 4)": 0.8292,
    "np.cumsum(a).tolist()": [2.0, 3.0, 4.0, 7.0],
    "float(np.trace(a))": 5.0,
    "np.outer([1, 2], [3, 4]).tolist()": [[3, 4], [6, 8]],
    "np.column_stack([[1, 2], [3, 4]]).tolist()": [[1, 3], [2, 4]],
    "np.clip(a, 1.5, 2.5).tolist()": [[2.0, 1.5], [1.5, 2.5]],
    "np.round(np.linalg.inv(a), 1).tolist()": [[0.6, -0.2], [-0.2, 0.4]],
    "np.round(np.linalg.pinv(a), 1).tolist()": [[0.6, -0.2], [-0.2, 0.4]],
    "np.round(np.linalg.solve(a, [1, 2]), 1).tolist()": [0.2, 0.6],
    "[round(float(v), 3) for v in np.linalg.svd(a)[1]]": [3.618, 1.382],
    "list(np.hstack([a, a]).shape) + list(np.vstack([a, a]).shape)": [2, 4, 4, 2],
    "list(np.concatenate([a, a]).shape) + list(np.stack([a, a]).shape)": [4, 2, 2, 2, 2],
    "float(np.ones_like(a).sum() + np.zeros_like(a).sum())": 4.0,
    "np.maximum(a, 2).tolist() + np.minimum(a, 2).tolist()": [[2.0, 2.0], [2.0, 3.0], [2.0, 1.0], [1.0, 2.0]],
    "[float(np.exp(0)), float(np.log(1)), float(np.square(3)), float(np.sqrt(4))]": [1.0, 0.0, 9.0, 2.0],
    "np.sign(-a).tolist()": [[-1.0, -1.0], [-1.0, -1.0]],
    "[bool(np.array_equal(a, a)), bool(np.isnan(a).any()), bool(np.isfinite(a).all())]": [True, False, True],
    "[float(np.floor(1.5)), float(np.ceil(1.5)), int(np.argmax(a)), int(np.argmin(a))]": [1.0, 2.0, 3, 1],
    "[float(a.mean()), float(a.max()), float(a.min()), float(a.sum()), float(a.std() > 0)]": [
        1.75,
        3.0,
        1.0,
        7.0,
        1.0,
    ],
    "[float(np.arccos(1)), float(np.arcsin(0)), float(np.arctan(0)), float(np.tan(0))]": [0.0, 0.0, 0.0, 0.0],
    "[float(np.rad2deg(np.pi)), float(np.deg2rad(180.0) - np.pi)]": [180.0, 0.0],
    "np.matmul(a, a).tolist() == np.dot(a, a).tolist() == (a @ a).tolist()": True,
    "[a.astype(np.float32).dtype == np.float32, np.asarray([1], dtype=np.int64).dtype == np.int64]": [
        True,
        True,
    ],
    "[str(a[0]), repr(a[0, 0]), f'{a[0, 0]:.3f}', '%.1f' % a[1, 1]]": [
        "[2. 1.]",
        "np.float64(2.0)",
        "2.000",
        "3.0",
    ],
    "list(a[np.newaxis].shape) + np.eye(2)[0].tolist()": [1, 2, 2, 1.0, 0.0],
    "[round(math.atan2(1, 1), 4), math.hypot(3, 4), round(float(np.pi + np.e), 3)]": [0.7854, 5.0, 5.86],
    "isinstance(a, np.ndarray) and np.float64(1) == 1.0 and np.uint8(3) == 3": True,
}


def test_every_numpy_stand_in_call_works_inside_the_sandbox() -> None:
    calls = list(NUMPY_CALLS)
    body = "".join(f"        {call},\n" for call in calls)
    source = (
        f"def program(input_scene):\n    a = np.array([[2.0, 1.0], [1.0, 3.0]])\n    return [\n{body}    ]\n"
    )
    result = run(
        source, limits=SandboxLimits(cpu_seconds=10, wall_seconds=20, memory_mb=1024, max_output_chars=50_000)
    )
    assert result.ok, result.error
    values = [
        json.loads(line) if line[:1] in "[-0123456789tf" else line for line in result.clue_text.splitlines()
    ]
    for call, value in zip(calls, values, strict=True):
        expected = NUMPY_CALLS[call]
        assert value == expected or str(value) == str(expected), f"{call}: {value!r} != {expected!r}"


# Every keyword argument the numpy surface lists, used as a program would (issue 38: everything else
# is refused). Each call runs in the sandbox and with the real numpy here; the two must agree.
KEYWORD_CALLS = [
    "np.all(a > 1, axis=0, keepdims=True)",
    "np.any(a > 2, axis=1, keepdims=True)",
    "np.max(a, axis=1, keepdims=True)",
    "np.min(a, axis=0, keepdims=True)",
    "np.argmax(a, axis=1, keepdims=True)",
    "np.argmin(a, axis=0, keepdims=True)",
    "np.median(a, axis=0, keepdims=True)",
    "np.sum(a, axis=0, dtype=np.float32, keepdims=True)",
    "np.sum(a, 1, np.int64)",
    "np.mean(a, axis=1, dtype=np.float64, keepdims=True)",
    "np.std(a, axis=0, dtype=np.float64, ddof=1, keepdims=True)",
    "np.cumsum(a, axis=1, dtype=np.int64)",
    "np.allclose(a, a + 1e-3, rtol=0, atol=1e-2, equal_nan=True)",
    "np.isclose(a, a + 1e-3, rtol=1e-2, atol=0, equal_nan=False)",
    "np.array_equal(a, a, equal_nan=True)",
    "np.sort(v, axis=0, kind='stable')",
    "np.argsort(v, axis=-1, stable=True)",
    "np.argsort(v, kind='stable')",
    "np.sort(v, stable=True)",
    "np.unique([3, 1, 3], return_index=True, return_inverse=True, return_counts=True)",
    "np.unique([[1, 1], [1, 1]], axis=0)",
    "np.array([1, 2], dtype=np.float32, copy=True, ndmin=2)",
    "np.array([1.5, 2.5], int)",
    "np.asarray([1.5, 2.5], dtype=np.int64)",
    "np.arange(1, stop=7, step=2, dtype=np.float64)",
    "np.linspace(0, 1, num=4, endpoint=False, retstep=True, dtype=np.float32, axis=0)",
    "np.zeros((2, 2), dtype=np.int32)",
    "np.ones(3, dtype=bool)",
    "np.zeros_like(a, dtype=np.int64)",
    "np.ones_like(a, dtype=np.uint8)",
    "np.eye(2, M=3, k=1, dtype=np.int64)",
    "np.diag(a, k=1)",
    "np.clip(a, a_min=1.5, a_max=2.5)",
    "np.clip(a, min=1.5, max=2.5)",
    "np.round(a / 3, decimals=2)",
    "np.transpose(a, axes=(1, 0))",
    "np.trace(a, offset=0, axis1=0, axis2=1)",
    "np.cross([[1, 0, 0]], [[0, 1, 0]], axisa=1, axisb=1, axisc=1)",
    "np.cross([1, 0, 0], [0, 1, 0], axis=0)",
    "np.concatenate([a, a], axis=1)",
    "np.stack([a, a], axis=2)",
    "np.linalg.norm(a, ord=1, axis=1, keepdims=True)",
    "np.linalg.pinv(a, rcond=1e-10, hermitian=True)",
    "np.linalg.pinv(a, rtol=1e-10)",
    "np.linalg.svd(a, full_matrices=False, compute_uv=False, hermitian=False)",
    "a.astype(dtype=np.int32)",
    "a.astype(np.float32)",
    "a[None].squeeze(axis=0)",
    "a.diagonal(offset=0, axis1=1, axis2=0)",
    "a.trace(offset=1, axis1=0, axis2=1)",
    "a.repeat(repeats=2, axis=0)",
    "a.take(indices=[1], axis=1)",
    "a.sum(axis=0, dtype=np.float32, keepdims=True)",
    "a.mean(axis=1, dtype=np.float64, keepdims=True)",
    "a.prod(axis=0, dtype=np.float64, keepdims=True)",
    "a.std(axis=0, dtype=np.float64, ddof=1, keepdims=True)",
    "a.var(axis=1, dtype=np.float64, ddof=0, keepdims=True)",
    "a.cumsum(axis=1, dtype=np.float64)",
    "a.cumprod(axis=0, dtype=np.float64)",
    "a.min(axis=0, keepdims=True)",
    "a.max(axis=1, keepdims=True)",
    "a.argmin(axis=1, keepdims=True)",
    "a.argmax(axis=0, keepdims=True)",
    "(a > 2).any(axis=0, keepdims=True)",
    "(a > 0).all(axis=1, keepdims=True)",
    "v.argsort(axis=0, kind='stable')",
    "v.argsort(stable=True)",
    "a.clip(min=1.5, max=2.5)",
    "(a / 3).round(decimals=2)",
    "np.float64(2.5).round(decimals=0)",
    "a.reshape(4, 1).transpose(1, 0).item(0, 2)",
]
KEYWORD_PROGRAM_PREFIX = "a = np.array([[2.0, 1.0], [1.0, 3.0]])\nv = np.array([3.0, -1.0, 2.0])\n"


def _called_keywords(call: str) -> set[tuple[str, str, str]]:
    """(table, function, keyword) for each keyword argument in `call`: FUNCTIONS, LINALG or METHODS."""
    found = set()
    for node in ast.walk(ast.parse(call)):
        if not isinstance(node, ast.Call) or not isinstance(node.func, ast.Attribute):
            continue
        owner = ast.unparse(node.func.value)
        table = {"np": "FUNCTIONS", "np.linalg": "LINALG_FUNCTIONS"}.get(owner, "METHODS")
        found |= {(table, node.func.attr, keyword.arg) for keyword in node.keywords}
    return found


def test_every_listed_keyword_argument_works_as_with_numpy() -> None:
    listed = {
        (table, name, keyword)
        for table in ("FUNCTIONS", "LINALG_FUNCTIONS", "METHODS")
        for name, accepted in getattr(numpy_surface, table).items()
        for keyword in accepted.keywords
    }
    used = set().union(*map(_called_keywords, KEYWORD_CALLS))
    assert listed - used == set(), "listed keywords no call below exercises"
    body = "".join(f"        ' '.join(repr({call}).split()),\n" for call in KEYWORD_CALLS)
    source = f"def program(input_scene):\n    {KEYWORD_PROGRAM_PREFIX.replace(chr(10), chr(10) + '    ')}"
    source += f"return [\n{body}    ]\n"
    result = run(
        source, limits=SandboxLimits(cpu_seconds=10, wall_seconds=20, memory_mb=1024, max_output_chars=50_000)
    )
    assert result.ok, result.error
    names = {"np": np}
    exec(KEYWORD_PROGRAM_PREFIX, names)
    expected = [" ".join(repr(eval(call, names)).split()) for call in KEYWORD_CALLS]
    for call, got, want in zip(KEYWORD_CALLS, result.clue_text.splitlines(), expected, strict=True):
        assert got == want, call


OPERATOR_PROGRAM = """
def program(input_scene):
    a = np.zeros(3)
    alias = a
    alias += 1                      # in place: `a` sees it
    alias[1:] *= 2
    alias[::2] -= np.array([0.5, 0.5])
    grid = np.ones((2, 3))
    grid[:, 0] *= 2
    grid[1, 1:] += 5
    calls = []
    counts = {'k': 1}
    key = lambda: calls.append(1) or 'k'
    counts[key()] += 1              # the key is evaluated once
    nested = [[1]]
    inner = nested[0]
    nested[0] += [2]                # lists extend in place
    text, pair, n, bits = 'x', (1,), 7, 6
    text += 'y'
    pair += (2,)
    n //= 2
    n **= 3
    n %= 5
    n -= 10
    n /= 4
    bits &= 3
    bits |= 8
    bits ^= 1
    bits <<= 2
    bits >>= 1
    label = ['%d-%s']
    label[0] %= (4, 'b')
    matrix = np.eye(2)
    matrix @= np.array([[1.0, 2.0], [3.0, 4.0]])
    scalar = np.float64(2)
    scalar *= 3
    plain = 7 // 2 + 2 ** 3 - (5 % 3) * 1.5 / 2, 6 & 3 | 8 ^ 1 << 2 >> 1
    return repr([a.tolist(), grid.tolist(), counts, len(calls), inner, text, pair, n, bits, label,
                 matrix.tolist(), float(scalar), plain])
"""


def test_operators_keep_python_semantics_behind_the_dtype_check() -> None:
    result = run(OPERATOR_PROGRAM)
    assert result.ok, result.error
    names = {"np": np}
    exec(OPERATOR_PROGRAM, names)
    assert result.clue_text == names["program"](None)


def test_numpy_lookups_that_import_lazily_work_through_the_attribute_check() -> None:
    # dtype.name imports a numpy module on first use; the attribute check (trusted code, real
    # builtins) makes that lookup, and the audit hook lets only already-loaded modules through.
    result = run("def program(input_scene):\n    return np.zeros(2).dtype.name\n")
    assert result.ok, result.error
    assert result.clue_text == "float64"


def test_tool_errors_reach_the_program_and_can_be_caught() -> None:
    caught = run(
        "def program(input_scene):\n"
        "    recon = pySpatial.reconstruct(input_scene)\n"
        "    try:\n"
        "        return pySpatial.synthesize_novel_view(recon, recon.extrinsics[0])\n"
        "    except pySpatial.ToolError as error:\n"
        "        return 'no view: ' + str(error)\n",
        PointSceneTools(fail_rendering=True),
    )
    assert caught.ok, caught.error
    assert caught.clue_text == "no view: synthesize_novel_view failed: RuntimeError: renderer exploded"

    uncaught = run(
        "def program(input_scene):\n"
        "    recon = pySpatial.reconstruct(input_scene)\n"
        "    return pySpatial.synthesize_novel_view(recon, recon.extrinsics[0])\n",
        PointSceneTools(fail_rendering=True),
    )
    assert not uncaught.ok and uncaught.error_kind == "exception"
    assert uncaught.error == (
        "program raised ToolError: synthesize_novel_view failed: RuntimeError: renderer exploded (line 3)"
    )


def test_unregistered_view_fails_clearly_in_the_pose_tools() -> None:
    result = run(
        "def program(input_scene):\n"
        "    recon = pySpatial.reconstruct(input_scene)\n"
        "    assert recon.registered == [True, False, True]\n"
        "    return pySpatial.rotate_left(recon.extrinsics[1])\n",
        PointSceneTools(unregistered=1),
    )
    assert not result.ok
    assert (
        result.error
        == "program raised ValueError: pySpatial.rotate_left: extrinsic contains NaN: that view was not "
        "registered by the reconstruction (see recon.registered), so it has no pose (line 4)"
    )


def test_program_errors_name_the_line() -> None:
    result = run("def program(input_scene):\n    values = [1, 2]\n    return values[5]\n")
    assert not result.ok and result.error_kind == "exception"
    assert result.error == "program raised IndexError: list index out of range (line 3)"


def test_tool_call_limit() -> None:
    limits = SandboxLimits(cpu_seconds=10, wall_seconds=20, memory_mb=1024, max_tool_calls=3)
    result = run(
        "def program(input_scene):\n"
        "    recon = pySpatial.reconstruct(input_scene)\n"
        "    texts = []\n"
        "    for i in range(5):\n"
        "        try:\n"
        "            texts.append(pySpatial.describe_camera_motion(recon))\n"
        "        except Exception as error:\n"
        "            texts.append(str(error))\n"
        "    return texts\n",
        limits=limits,
    )
    assert not result.ok and result.error_kind == "tool_limit"
    assert result.error == "too many tool calls: the limit is 3 per program"
    assert result.tool_calls == ["reconstruct", "describe_camera_motion", "describe_camera_motion"]


def test_image_count_limit() -> None:
    limits = SandboxLimits(cpu_seconds=10, wall_seconds=20, memory_mb=1024, max_images=2)
    result = run("def program(input_scene):\n    return input_scene.images\n", limits=limits)
    assert not result.ok and result.error_kind == "output"
    assert "returned 3 images; at most 2 are allowed" in result.error


def test_validator_accepts_ordinary_programs_and_explains_rejections() -> None:
    validate_program("import numpy as np\ndef program(input_scene):\n    return 'x'\n")
    with pytest.raises(ProgramRejected, match=r"line 1: imports are not allowed"):
        validate_program("import os\ndef program(input_scene):\n    return 'x'\n")
    with pytest.raises(ProgramRejected, match=r"must define a top-level function def program"):
        validate_program("def solve(input_scene):\n    return 'x'\n")
    with pytest.raises(ProgramRejected, match=r"line 2: 'type' is not available"):
        validate_program("def program(input_scene):\n    return type(input_scene)\n")
    with pytest.raises(ProgramRejected, match=r"syntax error at line 1"):
        validate_program("def program(input_scene)\n    return 1\n")


def test_per_program_overhead_is_small() -> None:
    timings = []
    for _ in range(3):
        started = time.perf_counter()
        result = run("def program(input_scene):\n    return 'ok'\n")
        timings.append(time.perf_counter() - started)
        assert result.ok and result.clue_text == "ok"
    print(f"sandbox overhead per program: min {min(timings) * 1e3:.0f} ms, max {max(timings) * 1e3:.0f} ms")
    assert min(timings) < 3.0  # a fresh interpreter + numpy import; generous for a loaded machine


def test_concurrent_runs_are_independent() -> None:
    # The agent service calls run_program from a thread pool; each run has its own process and tools.
    def run_one(index: int) -> tuple[int, str | None]:
        source = f"def program(input_scene):\n    return 'run {index} ' + str(len(input_scene.images))\n"
        result = run(source, images=index + 1)
        return index, result.clue_text if result.ok else result.error

    with ThreadPoolExecutor(max_workers=3) as pool:
        outcomes = sorted(pool.map(run_one, range(3)))
    assert outcomes == [(0, "run 0 1"), (1, "run 1 2"), (2, "run 2 3")]


# Ordinary model code that earlier versions refused or broke (issue 9, item 6).
FALSE_POSITIVES = (
    "from math import atan2\n"
    "from math import degrees as deg\n"
    "import numpy as np\n"
    "def program(input_scene):\n"
    "    count = 0\n"
    "    for _ in range(3):\n"
    "        count += 1\n"
    "    dir = 'left'\n"
    "    a = np.array([3, 1, 2, 3])\n"
    "    try:\n"
    "        np.linalg.inv(np.zeros((2, 2)))\n"
    "        singular = 'no'\n"
    "    except np.linalg.LinAlgError:\n"
    "        singular = 'yes'\n"
    "    return [count, dir, hasattr(input_scene, 'images'), format(3.14159, '.2f'), hex(255),\n"
    "            bool(np.all(a > 0)), bool(np.any(a > 2)), np.unique(a).tolist(), round(deg(atan2(1, 1))),\n"
    "            singular, isinstance(a, np.ndarray), isinstance('x', str), str.join('-', ['a', 'b'])]\n"
)
FALSE_POSITIVES_CLUE = "3\nleft\nTrue\n3.14\n0xff\nTrue\nTrue\n[1, 2, 3]\n45\nyes\nTrue\nTrue\na-b"


def test_ordinary_model_code_is_not_refused() -> None:
    result = run(FALSE_POSITIVES)
    assert result.ok, result.error
    assert result.clue_text == FALSE_POSITIVES_CLUE


def test_compile_errors_are_reported_as_they_are() -> None:
    result = run("def program(input_scene):\n    for x in range(3):\n        pass\n    continue\n")
    assert not result.ok and result.error_kind == "rejected"
    assert result.error == "rejected: syntax error at line 4: 'continue' not properly in loop"
