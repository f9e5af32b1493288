"""The pySpatial API as a sandboxed program sees it (runs in the child process).

Reconstruction, camera motion and rendering are requests to the parent over the tool channel; the
parent owns every pixel, so an `Image` here is only a handle (id, width, height). The pose tools
are pure numpy and run locally from `shared.geometry.poses`.

Extrinsics reach programs as 4x4 homogeneous camera-from-world matrices `[[R, t], [0, 0, 0, 1]]`
(the paper's API): `np.linalg.inv(E)` and `E1 @ np.linalg.inv(E2)` then just work, which is what
code models write. Every tool takes 3x4 or 4x4 and returns the shape it was given. Shape mistakes
are reported with the shapes, the convention and the helper that does the job.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np

from shared.geometry import poses

MIN_RENDER_SIZE = 16
MAX_RENDER_SIZE = 2048
EXTRINSIC_CONVENTION = (
    "an extrinsic is a 4x4 camera-from-world matrix [[R, t], [0, 0, 0, 1]] (3x4 [R | t] is accepted "
    "too): x_cam = R @ x_world + t, camera axes x right, y down, z forward; take one from "
    "recon.extrinsics[i] or from a pySpatial pose tool"
)


class ToolError(RuntimeError):
    """A pySpatial tool failed in the parent; programs may catch it."""


class ToolChannel(Protocol):
    def call(self, tool: str, arguments: dict[str, Any]) -> Any:
        """Ask the parent to run `tool`; return its reply or raise ToolError."""


class _Frozen:
    """Handles are read-only: a program cannot rewrite what the parent told it."""

    __slots__ = ()

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"{type(self).__name__} objects are read-only")

    def __delattr__(self, name: str) -> None:
        raise AttributeError(f"{type(self).__name__} objects are read-only")


class Image(_Frozen):
    """An image held by the parent. Input images learn their size from the parent on first use."""

    __slots__ = ("_handle", "_size", "_channel", "_input_index")

    def __init__(
        self,
        handle: str,
        size: tuple[int, int] | None,
        channel: ToolChannel,
        input_index: int | None = None,
    ) -> None:
        object.__setattr__(self, "_handle", handle)
        object.__setattr__(self, "_size", size)
        object.__setattr__(self, "_channel", channel)
        object.__setattr__(self, "_input_index", input_index)

    @property
    def id(self) -> str:
        return self._handle

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) in pixels."""
        if self._size is None:
            reply = self._channel.call("get_input_image", {"index": self._input_index})
            object.__setattr__(self, "_size", (int(reply["width"]), int(reply["height"])))
        return self._size

    @property
    def width(self) -> int:
        return self.size[0]

    @property
    def height(self) -> int:
        return self.size[1]

    def __repr__(self) -> str:
        size = f" {self._size[0]}x{self._size[1]}" if self._size else ""
        return f"<Image {self._handle}{size}>"


class Scene(_Frozen):
    __slots__ = ("_images", "_question")

    def __init__(self, images: list[Image], question: str) -> None:
        object.__setattr__(self, "_images", list(images))
        object.__setattr__(self, "_question", question)

    @property
    def images(self) -> list[Image]:
        return list(self._images)  # a copy: the program may reorder it freely

    @property
    def question(self) -> str:
        return self._question

    def __repr__(self) -> str:
        return f"<Scene with {len(self._images)} images>"


class Reconstruction(_Frozen):
    """Cameras of the reconstructed scene (the point cloud stays with the reconstruction service)."""

    __slots__ = ("_extrinsics", "_intrinsics", "_image_sizes", "_registered", "_up", "_warnings", "_units")

    def __init__(self, payload: dict[str, Any]) -> None:
        extrinsics = [np.asarray(matrix, dtype=np.float64).reshape(3, 4) for matrix in payload["extrinsics"]]
        intrinsics = [np.asarray(matrix, dtype=np.float64).reshape(3, 3) for matrix in payload["intrinsics"]]
        registered = [bool(flag) for flag in payload.get("registered", [True] * len(extrinsics))]
        object.__setattr__(self, "_extrinsics", extrinsics)
        object.__setattr__(self, "_intrinsics", intrinsics)
        object.__setattr__(
            self, "_image_sizes", [tuple(int(v) for v in size) for size in payload["image_sizes"]]
        )
        object.__setattr__(self, "_registered", registered)
        object.__setattr__(self, "_up", _scene_up(payload.get("up"), extrinsics, registered))
        object.__setattr__(self, "_warnings", [str(text) for text in payload.get("warnings") or []])
        object.__setattr__(self, "_units", str(payload.get("units") or "relative"))

    @property
    def extrinsics(self) -> list[np.ndarray]:
        """One 4x4 camera-from-world matrix per view (unregistered views: all NaN)."""
        return [_homogeneous(matrix) for matrix in self._extrinsics]

    @property
    def intrinsics(self) -> list[np.ndarray]:
        return [matrix.copy() for matrix in self._intrinsics]

    @property
    def units(self) -> str:
        """ "metres" (a metric reconstruction: pi3x, posed-rgbd) or "relative" (arbitrary scale).

        `move_forward(pose, 0.3)` moves 0.3 of these: 0.3 m in a metric scene.
        """
        return self._units

    @property
    def image_sizes(self) -> list[tuple[int, int]]:
        return list(self._image_sizes)

    @property
    def registered(self) -> list[bool]:
        return list(self._registered)

    @property
    def num_views(self) -> int:
        return len(self._extrinsics)

    @property
    def up(self) -> np.ndarray | None:
        return None if self._up is None else self._up.copy()

    @property
    def warnings(self) -> list[str]:
        return list(self._warnings)

    def __repr__(self) -> str:
        return f"<Reconstruction of {self.num_views} views>"


def _homogeneous(matrix: np.ndarray) -> np.ndarray:
    square = np.eye(4)
    square[:3, :] = matrix
    if not np.all(np.isfinite(matrix)):
        square[3, :] = np.nan  # an unregistered view has no pose at all, not half of one
    return square


def _extrinsic(value: Any, tool: str, argument: str = "extrinsic") -> np.ndarray:
    """`value` as a validated float 3x4 or 4x4 pose, or a ValueError a code model can act on."""
    try:
        matrix = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(
            f"pySpatial.{tool}: {argument} must be a pose matrix, got {type(value).__name__}; "
            f"{EXTRINSIC_CONVENTION}"
        ) from None
    if matrix.shape not in ((3, 4), (4, 4)):
        hint = ""
        if matrix.shape == (3,):
            hint = " (that is a 3D point; pass the camera's pose, e.g. recon.extrinsics[0])"
        elif matrix.shape == (3, 3):
            hint = " (that is a rotation or an intrinsic matrix, not a pose)"
        raise ValueError(
            f"pySpatial.{tool}: {argument} must be 3x4 or 4x4, got shape {matrix.shape}{hint}; "
            f"{EXTRINSIC_CONVENTION}"
        )
    if not np.all(np.isfinite(matrix)):
        raise ValueError(
            f"pySpatial.{tool}: {argument} contains NaN: that view was not registered by the "
            "reconstruction (see recon.registered), so it has no pose"
        )
    try:
        return poses.validate_extrinsic(matrix)
    except ValueError as error:
        raise ValueError(f"pySpatial.{tool}: {argument}: {error}; {EXTRINSIC_CONVENTION}") from None


def _point(value: Any, tool: str) -> np.ndarray:
    try:
        vector = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise TypeError(f"pySpatial.{tool}: point must be 3 numbers (x, y, z) in world coordinates") from None
    if vector.shape == (4,) and abs(vector[3]) > 1e-12:
        vector = vector[:3] / vector[3]  # a homogeneous point
    if vector.shape != (3,) or not np.all(np.isfinite(vector)):
        raise ValueError(
            f"pySpatial.{tool}: point must be 3 finite numbers (x, y, z) in world coordinates "
            f"(or homogeneous (x, y, z, 1)), got shape {np.asarray(value).shape}"
        )
    return vector


def _scene_up(reported: Any, extrinsics: list[np.ndarray], registered: list[bool]) -> np.ndarray | None:
    if reported is not None:
        vector = np.asarray(reported, dtype=np.float64).reshape(-1)
        if vector.shape == (3,) and np.all(np.isfinite(vector)) and np.linalg.norm(vector) > 1e-9:
            return vector / np.linalg.norm(vector)
    usable = [
        pose for pose, ok in zip(extrinsics, registered, strict=False) if ok and np.all(np.isfinite(pose))
    ]
    if not usable:
        return None
    try:
        return poses.estimate_up_axis(np.stack(usable))
    except ValueError:
        return None


class PySpatial(_Frozen):
    """The `pySpatial` object of a program.

    Pose tools turn about the scene up of the latest reconstruction when there is one (so turns keep
    the horizon level), else about the camera's own up (see shared.geometry.poses).
    """

    __slots__ = ("_channel", "_scene", "_up")
    ToolError = ToolError  # so programs can write `except pySpatial.ToolError`

    def __init__(self, channel: ToolChannel, scene: Scene) -> None:
        object.__setattr__(self, "_channel", channel)
        object.__setattr__(self, "_scene", scene)
        object.__setattr__(self, "_up", None)

    def reconstruct(self, scene: Scene) -> Reconstruction:
        if scene is not self._scene:
            raise TypeError("reconstruct(scene) takes the input_scene passed to program()")
        reconstruction = Reconstruction(self._channel.call("reconstruct", {}))
        object.__setattr__(self, "_up", reconstruction.up)
        return reconstruction

    def describe_camera_motion(
        self, recon: Reconstruction, from_view: Any = None, to_view: Any = None
    ) -> str:
        """Consecutive pairs' sentences; with from_view and to_view (1-based, as the question counts
        images) the one sentence of that pair, consecutive or not. In the
        earlier view's image axes (plus the gravity frame when it says otherwise): step with its size,
        turn, tilt, roll, or stayed still."""
        _require_reconstruction(recon, "describe_camera_motion")
        if from_view is None and to_view is None:
            sentences = self._channel.call("describe_camera_motion", {})
        else:
            pair = _view_pair(from_view, to_view, recon.num_views)
            views = {"from_view": pair[0], "to_view": pair[1]}
            sentences = self._channel.call("describe_camera_motion", views)
        return "\n".join(str(sentence) for sentence in sentences)

    def synthesize_novel_view(
        self, recon: Reconstruction, new_extrinsic: Any, width: int = 512, height: int = 512
    ) -> Image:
        """The scene rendered from `new_extrinsic` (camera-from-world), `width` x `height` pixels."""
        _require_reconstruction(recon, "synthesize_novel_view")
        pose = _extrinsic(new_extrinsic, "synthesize_novel_view", "new_extrinsic")[:3, :]
        for label, value in (("width", width), ("height", height)):
            if not isinstance(value, int | np.integer) or not MIN_RENDER_SIZE <= value <= MAX_RENDER_SIZE:
                raise ValueError(f"{label} must be an integer from {MIN_RENDER_SIZE} to {MAX_RENDER_SIZE}")
        reply = self._channel.call(
            "synthesize_novel_view", {"extrinsic": pose.tolist(), "width": int(width), "height": int(height)}
        )
        return Image(str(reply["id"]), (int(reply["width"]), int(reply["height"])), self._channel)

    def rotate_left(self, extrinsic: Any, angle: float = 45.0) -> np.ndarray:
        """The same camera turned left by `angle` degrees about the scene up, in place."""
        pose = _extrinsic(extrinsic, "rotate_left")
        return poses.rotate_left(pose, _number(angle, "angle"), up=self._up)

    def rotate_right(self, extrinsic: Any, angle: float = 45.0) -> np.ndarray:
        """The same camera turned right by `angle` degrees about the scene up, in place."""
        pose = _extrinsic(extrinsic, "rotate_right")
        return poses.rotate_right(pose, _number(angle, "angle"), up=self._up)

    def move_forward(self, extrinsic: Any, distance: float = 0.3) -> np.ndarray:
        """Move `distance` along the view, in scene units (the reconstruction's own: `recon.units`)."""
        pose = _extrinsic(extrinsic, "move_forward")
        return poses.move_forward(pose, _number(distance, "distance"), up=self._up)

    def move_backward(self, extrinsic: Any, distance: float = 0.3) -> np.ndarray:
        """Move `distance` against the view, in scene units (as move_forward)."""
        pose = _extrinsic(extrinsic, "move_backward")
        return poses.move_backward(pose, _number(distance, "distance"), up=self._up)

    def turn_around(self, extrinsic: Any) -> np.ndarray:
        """The same camera turned by 180 degrees about the scene up, in place."""
        return poses.turn_around(_extrinsic(extrinsic, "turn_around"), up=self._up)

    def locate(self, recon: Reconstruction, view: int, u: float, v: float) -> dict:
        """The world point seen at pixel (u, v) (column, row, in pixels) of view `view` (1-based, as
        the question counts images: view 1 is recon.extrinsics[0]):
        {"point": 3-vector in world coordinates (scene units) or None, "reason": why there is none}."""
        _require_reconstruction(recon, "locate")
        index = _view_index(view, recon, "locate")
        reply = self._channel.call("locate", {"view": index, "u": _number(u, "u"), "v": _number(v, "v")})
        point = reply.get("point")
        return {
            "point": None if point is None else np.asarray(point, dtype=float),
            "reason": reply.get("reason"),
        }

    def plan_route(
        self, recon: Reconstruction, start_view: int, goal: Any, robot_radius: float = 0.25
    ) -> dict:
        """A robot's route from the floor below view `start_view`'s camera (1-based, as the question
        counts images) to the world point `goal` (scene units); `robot_radius` in metres:
        {"reachable", "summary", "steps": [{"turn_degrees" (degrees, + = left), "move" (in "units")}],
        "sentences", "length", "units" ("metres" or "scene units"), "reason", ...}."""
        _require_reconstruction(recon, "plan_route")
        index = _view_index(start_view, recon, "plan_route")
        radius = _number(robot_radius, "robot_radius")
        if not 0 < radius <= 5:
            raise ValueError("robot_radius must be in (0, 5] metres")
        target = _point(goal, "plan_route").tolist()
        return dict(
            self._channel.call("plan_route", {"start_view": index, "goal": target, "robot_radius": radius})
        )

    # ---- helpers code models reach for --------------------------------------------------------

    def camera_center(self, extrinsic: Any) -> np.ndarray:
        """Where the camera is, in world coordinates (scene units): `-R.T @ t` (a 3-vector)."""
        return poses.camera_center(_extrinsic(extrinsic, "camera_center"))

    def relative_pose(self, from_extrinsic: Any, to_extrinsic: Any) -> np.ndarray:
        """4x4 matrix taking coordinates in the first camera's frame to the second camera's frame."""
        first = poses.as_4x4(_extrinsic(from_extrinsic, "relative_pose", "from_extrinsic"))
        second = poses.as_4x4(_extrinsic(to_extrinsic, "relative_pose", "to_extrinsic"))
        return second @ np.linalg.inv(first)

    def heading_angle(self, from_extrinsic: Any, to_extrinsic: Any) -> float:
        """How far the viewing direction turned from the first view to the second, about the scene up.

        Degrees in (-180, 180], + = left (counter-clockwise seen from above), - = right: the sign of
        every horizontal angle here (rotate_left, camera motion's turn, plan_route's turn_degrees).
        """
        first = _extrinsic(from_extrinsic, "heading_angle", "from_extrinsic")
        second = _extrinsic(to_extrinsic, "heading_angle", "to_extrinsic")
        up = self._up if self._up is not None else poses.estimate_up_axis(np.stack([first[:3], second[:3]]))
        forward_first = poses.horizontal_forward(first[:3, :3], up)
        forward_second = poses.horizontal_forward(second[:3, :3], up)
        left_first = np.cross(up, forward_first)
        return float(np.degrees(np.arctan2(forward_second @ left_first, forward_second @ forward_first)))

    def distance_to_point(self, extrinsic: Any, point: Any) -> float:
        """Distance from the camera's centre to a world point, in scene units (the reconstruction's)."""
        centre = poses.camera_center(_extrinsic(extrinsic, "distance_to_point"))
        return float(np.linalg.norm(_point(point, "distance_to_point") - centre))

    def __repr__(self) -> str:
        return "<pySpatial API>"


def _view_pair(from_view: Any, to_view: Any, views: int) -> tuple[int, int]:
    """Both views as plain ints 1..views (numbered as the question numbers images), and different."""
    pair = []
    for label, value in (("from_view", from_view), ("to_view", to_view)):
        if isinstance(value, bool) or not isinstance(value, int | np.integer):
            raise TypeError(f"describe_camera_motion: {label} must be a view number 1..{views}: {value!r}")
        if not 1 <= int(value) <= views:
            raise ValueError(
                f"describe_camera_motion: {label}={int(value)}, but views are numbered 1..{views} "
                "(image 1 is view 1; recon.extrinsics[0] is view 1)"
            )
        pair.append(int(value))
    if pair[0] == pair[1]:
        raise ValueError("describe_camera_motion: from_view and to_view must be different views")
    return pair[0], pair[1]


def _require_reconstruction(value: Any, tool: str) -> None:
    if not isinstance(value, Reconstruction):
        raise TypeError(f"{tool} takes the Reconstruction returned by pySpatial.reconstruct(input_scene)")


def _view_index(value: Any, recon: Reconstruction, tool: str) -> int:
    """A view number (1-based, as the question counts images) as the index the parent takes."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(f"{tool}: the view is a view number 1..{recon.num_views}, got {type(value).__name__}")
    if not 1 <= int(value) <= recon.num_views:
        raise ValueError(
            f"{tool}: view {int(value)} does not exist; views are numbered 1..{recon.num_views} "
            "(image 1 is view 1; recon.extrinsics[0] is view 1)"
        )
    return int(value) - 1


def _number(value: Any, label: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise TypeError(f"{label} must be a number, got {type(value).__name__}")
    if not np.isfinite(value):
        raise ValueError(f"{label} must be finite")
    return float(value)


def build_scene(num_images: int, question: str, channel: ToolChannel) -> Scene:
    images = [Image(f"input:{index}", None, channel, input_index=index) for index in range(num_images)]
    return Scene(images, question)
