"""Pydantic models of both HTTP APIs: the single source of their contracts (and OpenAPI docs)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from shared.questions.intent import QuestionIntent
from shared.questions.reading import QuestionReading

Matrix = list[list[float]]
ImageFormat = Literal["png", "jpeg"]
Units = Literal["metres", "relative"]
UNITS_DESCRIPTION = (
    "What one unit of the world frame is: metres (pi3x's metric head; posed-rgbd, whose depths are "
    "metres) or relative (classical, vggt, pi3: an arbitrary scale, only ratios of lengths mean anything)."
)
SCENE_ID_PATTERN = r"^[0-9a-f]{24}$"  # content hash prefix, see services/recon/scene_store.py
# Names the tenant a service key acts for (the agent's calls to recon); see shared/wire/access.py.
TENANT_HEADER = "X-PySpatial-Tenant"


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid")


# ---- reconstruction service ----------------------------------------------------------------


class SceneUpload(_Model):
    """JSON form of a scene upload (multipart form uploads use the field `images` for files)."""

    images: list[str] = Field(..., description="Images in order, base64 or data URLs (PNG, JPEG, ...).")
    depths: list[str] | None = Field(
        None, description="Optional per-view z-depth, base64 of a float32 .npy (H, W), for posed-rgbd."
    )
    extrinsics: list[Matrix] | None = Field(None, description="Optional 3x4 camera-from-world, OpenCV axes.")
    intrinsics: list[Matrix | None] | None = Field(
        None,
        description="Optional 3x3 intrinsics in pixels of the upright image (EXIF orientation applied), "
        "one per view; null for a view whose camera is unknown (its EXIF focal length is used if any).",
    )


class SceneInfo(_Model):
    scene_id: str = Field(
        ...,
        description="Content hash of the images (and depths/cameras) in order; for a named tenant, an HMAC "
        "of it under the tenant's secret (the same upload is the same id within a tenant only).",
    )
    num_images: int
    image_sizes: list[tuple[int, int]] = Field(..., description="(width, height) per image.")
    has_depth: bool
    has_cameras: bool
    kind: Literal["photos", "posed-rgbd"] = Field(
        "photos",
        description="What was uploaded: posed-rgbd (every view's depth, pose and intrinsics) or photos. "
        "A request that names no backbone reconstructs a posed-rgbd scene with posed-rgbd, on every "
        "replica (the kind is stored with the scene).",
    )


class SceneCreated(SceneInfo):
    created: bool = Field(..., description="False when the same scene had been uploaded before.")


class ReconstructRequest(_Model):
    backbone: str | None = Field(
        None, description="classical, posed-rgbd or vggt; the service default if unset."
    )


class ViewConfidenceInfo(_Model):
    """How well the data supports a view's pose; null where the backbone does not measure it."""

    inliers: int = Field(..., description="Observations that agree with the model.")
    spread: float | None = Field(None, description="Share of the image (4x4 cells) the inliers cover.")
    reprojection_error_px: float | None = Field(
        None, description="Median over the inliers after adjustment, pixels."
    )
    positive_depth_fraction: float | None = Field(None, description="Share of its points in front of it.")
    unregistered_reason: str | None = Field(None, description="Why the view has no pose; null if registered.")
    uncertain_reason: str | None = Field(
        None, description="Why a registered view's pose is uncertain (e.g. its position); null if not."
    )


# One view numbering (docs/ARCHITECTURE.md, "View numbers"): every JSON field that names a view,
# and every text for people, counts views from 1, as questions say "image 1"; only the positions of
# JSON lists (cameras[0] is view 1) and the geometry inside the services are 0-based.
VIEW_NUMBERS = " Views are numbered from 1 in every field and text; a JSON list's first item is view 1."
ViewNumber = Annotated[int, Field(ge=1)]


class PairConfidenceInfo(_Model):
    first: int = Field(..., ge=1, description="The first view (1-based, as `cameras[].view`).")
    second: int = Field(..., ge=1, description="The second view (1-based).")
    inliers: int = Field(..., description="Points both views see.")
    reprojection_error_px: float | None = None
    triangulation_angle_deg: float | None = Field(None, description="Median angle between their rays.")
    rotation_uncertainty_deg: float | None = Field(
        None, description="One standard deviation of their relative rotation, degrees; null if not estimated."
    )
    direction_uncertainty_deg: float | None = Field(
        None, description="One standard deviation of the direction of travel between them, degrees."
    )
    uncertain_reason: str | None = Field(
        None,
        description="Why their relative pose is not confident, naming the configuration (small "
        "triangulation angle, near-pure rotation, near-planar); null when it is confident.",
    )


class CameraInfo(_Model):
    view: int = Field(
        ..., ge=1, description="The view: the photo's place in the upload, 1-based." + VIEW_NUMBERS
    )
    extrinsic: Matrix | None = Field(..., description="3x4 camera-from-world; null when not registered.")
    intrinsic: Matrix | None = Field(..., description="3x3 in pixels; null when the backbone has none.")
    intrinsics_source: str | None = Field(
        None,
        description="Where the intrinsics came from: uploaded, exif, self-calibrated (classical: "
        "estimated from the views), prior (a guessed field of view), given (posed-rgbd), predicted "
        "(vggt; pi3 and pi3x: fitted to the predicted points); null when not reported.",
    )
    width: int
    height: int
    registered: bool
    confidence: ViewConfidenceInfo | None = None


class ReconstructionSummary(_Model):
    scene_id: str
    backbone: str
    backbone_version: str
    cameras: list[CameraInfo]
    num_points: int
    bounds_min: list[float]
    bounds_max: list[float]
    up: list[float] = Field(..., description="Scene up axis estimated from the cameras (world frame).")
    units: Units = Field("relative", description=UNITS_DESCRIPTION)
    warnings: list[str]
    pairs: list[PairConfidenceInfo] = Field(
        default_factory=list, description="Support of each pair of registered views (classical)."
    )
    cached: bool = Field(..., description="Served from the cache without reconstructing.")
    joined_in_flight: bool = Field(
        False, description="Waited for an identical reconstruction already running."
    )
    timings_ms: dict[str, float]


# A pose as routes take it: 3 or 4 rows of 4 numbers (the schema says so; rotation checked by the service).
PoseMatrix = Annotated[
    list[Annotated[list[float], Field(min_length=4, max_length=4)]], Field(min_length=3, max_length=4)
]
RENDER_SIDE = "Pixels; at most PYSPATIAL_MAX_RENDER_SIDE (2048 by default), else a 422."


class RenderRequest(_Model):
    scene_id: str = Field(..., pattern=SCENE_ID_PATTERN, description="A scene id from POST /v1/scenes.")
    extrinsic: PoseMatrix = Field(
        ..., description="3x4 or 4x4 camera-from-world, OpenCV axes; the rotation must be orthonormal."
    )
    width: Annotated[int, Field(ge=16, description=RENDER_SIDE)] = 512
    height: Annotated[int, Field(ge=16, description=RENDER_SIDE)] = 512
    zoom_out: Annotated[float, Field(gt=0.0, le=4.0)] = 0.5
    format: ImageFormat = "png"
    backbone: str | None = None


class PixelTarget(_Model):
    """An object located by a pixel of one photo: the nearest reconstructed surface there."""

    view: Annotated[int, Field(ge=1, description="The view the pixel is in (1-based).")]
    u: Annotated[float, Field(description="Column, in that photo's pixels.")]
    v: Annotated[float, Field(description="Row, in that photo's pixels.")]


class MotionTarget(_Model):
    """What "closer to" / "farther from" is measured against: exactly one of the three."""

    point: tuple[float, float, float] | None = Field(None, description="A world point.")
    pixel: PixelTarget | None = None
    scene_centre: bool = Field(False, description="The median of the reconstructed points.")
    name: str | None = Field(None, max_length=80, description="How the sentences call it ('the chair').")


class CameraMotionRequest(_Model):
    scene_id: str = Field(..., pattern=SCENE_ID_PATTERN, description="A scene id from POST /v1/scenes.")
    pairs: list[tuple[ViewNumber, ViewNumber]] | None = Field(
        None, description="View pairs (from, to), 1-based; consecutive if unset." + VIEW_NUMBERS
    )
    from_view: int | None = Field(
        None,
        ge=1,
        description="With to_view: the one pair from_view -> to_view, 1-based as the sentences "
        "and questions count views (any pair, not only consecutive ones). Not together with pairs.",
    )
    to_view: int | None = Field(None, ge=1, description="See from_view.")
    backbone: str | None = None
    target: MotionTarget | None = Field(
        None, description="Say per pair whether the camera came closer to it."
    )

    @model_validator(mode="after")
    def _one_way_to_name_pairs(self) -> CameraMotionRequest:
        if (self.from_view is None) != (self.to_view is None):
            raise ValueError("from_view and to_view go together")
        if self.from_view is not None and self.pairs is not None:
            raise ValueError("give either pairs or from_view and to_view, not both")
        if self.from_view is not None and self.from_view == self.to_view:
            raise ValueError("from_view and to_view must be different views")
        return self

    def requested_pairs(self) -> list[tuple[int, int]] | None:
        """The pairs asked for as indices (0-based, as the geometry takes them); None: the default
        (consecutive) pairs."""
        if self.from_view is not None and self.to_view is not None:
            return [(self.from_view - 1, self.to_view - 1)]
        return None if self.pairs is None else [(first - 1, second - 1) for first, second in self.pairs]


class FrameMotionItem(_Model):
    """One pair's motion read in one frame."""

    frame: Literal["image", "gravity"] = Field(
        ..., description="image: the first view's camera axes; gravity: the scene's estimated or given up."
    )
    right: float = Field(..., description="Step along the frame's right axis (units of the reconstruction).")
    up: float = Field(..., description="Step along the frame's up axis.")
    forward: float = Field(..., description="Step along the frame's forward axis.")
    direction: str = Field(..., description="Compass direction in the right-forward plane, or no movement.")
    vertical_direction: str | None = Field(None, description="'up', 'down', or null when not significant.")
    turn_deg: float = Field(..., description="Turn (pan, yaw); + = left.")
    tilt_deg: float = Field(..., description="Tilt (pitch); + = up.")
    roll_deg: float = Field(
        ...,
        description="Roll; + = clockwise seen from behind the camera (the photo turns the other way).",
    )
    phrase: str = Field(
        ..., description="This frame's words, e.g. 'moved down and tilted up by about 8 degrees'."
    )


class MotionThresholds(_Model):
    """Below these a step or a rotation is not said; below all of them the camera stayed still."""

    distance: float = Field(..., description="Smallest step said (units of the reconstruction).")
    distance_fraction_of_scene: float = Field(..., description="`distance` as a fraction of `scene_scale`.")
    scene_scale: float
    turn_deg: float
    tilt_deg: float
    roll_deg: float


class BackboneEntry(_Model):
    name: str
    available: bool = Field(..., description="Whether a request naming it can run now.")
    reason: str | None = Field(None, description="Why not, with what to run; null when available.")
    units: Units = Field(..., description=UNITS_DESCRIPTION)
    device: str = Field(..., description="Where it would run: cpu, cuda, ...")
    note: str | None = Field(None, description="What it needs from an upload, where that matters.")


class BackboneMenu(_Model):
    default: str = Field(..., description="The backbone a request without one gets (may be auto).")
    auto: str = Field(..., description="What `auto` stands for now: pi3x, else vggt, else classical.")
    backbones: list[BackboneEntry]
    available: list[str] = Field(..., description="Names a request may use now (auto included).")


class QuantityOverFocalItem(_Model):
    """One quantity of the motion vocabulary over every supported focal hypothesis."""

    words: list[str] = Field(
        ...,
        description="The distinct words the hypotheses give, in increasing field of view; 'none' where "
        "a hypothesis has none of it (below the thresholds).",
    )
    range: list[float] | None = Field(
        None,
        description="[min, max] over the hypotheses: degrees for turn (+ left), tilt (+ up), roll (+ "
        "clockwise) and direction (heading, 0 forward, + = left); for lateral (+ right), depth (+ "
        "forward) and vertical (+ up), that component of the unit step; null for still.",
    )
    determined: bool = Field(..., description="True when every hypothesis gives the same word.")


class MotionOverFocalItem(_Model):
    """A pair's motion at every focal hypothesis the photos support, and what all of them share."""

    hypotheses: int = Field(..., description="How many field-of-view hypotheses the matches support.")
    fov_range_deg: list[float] = Field(
        ..., description="[narrowest, widest] supported horizontal field of view."
    )
    yaw_range_deg: list[float] = Field(
        ..., description="[min, max] turn over the hypotheses, in the first view's image axes; + = left."
    )
    turns: list[str] = Field(..., description="The distinct turn sides: 'left', 'right', 'none'.")
    turn_determined: bool = Field(..., description="True when every hypothesis turns the same way.")
    directions: list[str] = Field(..., description="The distinct horizontal step directions.")
    direction_determined: bool
    heading_range_deg: list[float] | None = Field(
        None,
        description="[min, max] heading of the step over the hypotheses (0 forward, + = left); "
        "null if none moved.",
    )
    vertical_directions: list[str] = Field(
        ..., description="The distinct vertical steps: 'up', 'down', 'none'."
    )
    vertical_determined: bool
    translation_directions: list[list[float]] = Field(
        ...,
        description="Per hypothesis, the unit step in the first camera's axes (x right, y down, z forward).",
    )
    sentence: str = Field(..., description="What holds at every hypothesis (determined) and what does not.")
    frame: Literal["image"] = Field(
        "image", description="The first view's camera axes, in which every word above is read."
    )
    quantities: dict[str, QuantityOverFocalItem] = Field(
        default_factory=dict,
        description="Every quantity of the vocabulary: turn, tilt, roll, direction (compass step), "
        "lateral (left/right), depth (forward/backward), vertical (up/down), still.",
    )
    fov_assumption: str | None = Field(
        None,
        description="Set when an assumption about the scene, not the matches, ruled out the narrower "
        "fields of view (fov_range_deg starts above the grid's): what was assumed.",
    )


class CameraMotionItem(_Model):
    """One pair of views: a description, or (described = false) the reason there is none."""

    from_view: int = Field(..., ge=1, description="The first view (1-based)." + VIEW_NUMBERS)
    to_view: int = Field(..., ge=1, description="The second view (1-based).")
    described: bool = Field(True, description="False when the motion is unknown; `reason` says why.")
    reason: str | None = Field(None, description="Why there is no description (unregistered view, ...).")
    direction: str | None = Field(None, description="Horizontal direction, or 'no significant movement'.")
    vertical_direction: str | None = Field(None, description="'up', 'down', or null when not significant.")
    angle_deg: float | None = Field(
        None,
        description="Heading of the horizontal step in the first view's image axes, degrees: 0 forward, "
        "+90 = left, -90 = right (left-positive, as every horizontal angle here).",
    )
    distance: float | None = Field(None, description="Length of the step, in `units`.")
    displacement_in_first_camera: list[float] | None = None
    vertical: float | None = Field(None, description="Displacement along the up axis (positive = up).")
    yaw_deg: float | None = Field(None, description="Turn about the up axis between the views; + = left.")
    turn: str | None = Field(None, description="The turn in words, e.g. 'turned left by about 90 degrees'.")
    sentence: str = Field(..., description="The motion in one sentence, or that it is unknown and why.")
    units: Units | None = Field(None, description="Units of distance and vertical (null when unknown).")
    image: FrameMotionItem | None = Field(
        None, description="In the first view's camera axes (the sentence's frame)."
    )
    gravity: FrameMotionItem | None = Field(
        None, description="In the scene's gravity frame; null when up is not reliably known."
    )
    frames_differ: bool | None = Field(
        None, description="The two frames' words differ; the sentence gives both."
    )
    still: bool | None = Field(None, description="Below every threshold: the camera stayed still.")
    thresholds: MotionThresholds | None = None
    target_change: Literal["closer", "farther", "same distance"] | None = Field(
        None, description="Camera j against camera i, relative to the request's target."
    )
    target_distances: list[float] | None = Field(
        None, description="Camera i's and j's distances to the target."
    )
    over_focal: MotionOverFocalItem | None = Field(
        None,
        description="Set when the focal length is unknown and the views cannot fix it: the motion over "
        "every supported field of view (the numbers above are the central hypothesis's, and `sentence` "
        "says what is determined); null when the focal is known or self-calibrated.",
    )


class CameraMotionResponse(_Model):
    scene_id: str
    backbone: str
    motions: list[CameraMotionItem]
    text: str = Field(..., description="The sentences, one per line (unknown pairs included).")
    scene_scale: float = Field(..., description="Size of the scene (units of the reconstruction).")
    warnings: list[str] = Field(default_factory=list)


class PointCloudPreview(_Model):
    """A subsample of a reconstruction for viewers: points, colours and the cameras."""

    scene_id: str
    backbone: str
    num_points_total: int
    num_points: int
    positions: str = Field(..., description="base64 of little-endian float32 (num_points, 3), world frame.")
    colors: str = Field(..., description="base64 of uint8 RGB (num_points, 3).")
    confidence: str | None = Field(
        None,
        description="base64 of little-endian float32 (num_points,): each point's confidence (the "
        "backbone's scale, higher is surer); the points are then sorted by it, most confident first. "
        "Null when the reconstruction has none (the points are in their stored order).",
    )
    cameras: list[CameraInfo]
    up: list[float]


class ExampleQuestion(_Model):
    text: str
    expected_answer: str | None = Field(None, description="The option letter the data determine.")
    expected_words: str | None = Field(None, description="Free-form: words the right answer contains.")
    free_form: bool = Field(False, description="No lettered options: it is answered in words.")


class ExampleInfo(_Model):
    """One bundled example of the page's gallery."""

    name: str
    title: str
    description: str
    source: Literal["synthetic", "real"]
    citation: str | None = Field(None, description="Where real photos come from, to cite them.")
    thumbnail: str = Field(..., description="URL of a small picture of it (a JPEG of its first photo).")
    images: list[str] = Field(..., description="URLs of its photos, in order.")
    questions: list[ExampleQuestion]


class ExampleList(_Model):
    examples: list[ExampleInfo]


class Readiness(_Model):
    ready: bool
    backbone: str
    backbone_ready: bool
    backbone_detail: str
    cache: str = Field(..., description="redis, memory, or redis-unavailable (serving from memory).")
    storage: str = Field("ok", description="ok, or what keeps scenes from being stored (recon data dir).")
    warnings: list[str]


# ---- agent service -------------------------------------------------------------------------


class SandboxStatus(_Model):
    jail: str = Field(..., description="'active', 'off (operator opt-out)' or 'unavailable'.")
    runs_programs: bool = Field(..., description="Whether generated programs are run at all.")
    detail: str = Field(..., description="How the jail was set up, or why it could not be.")


class AgentReadiness(_Model):
    ready: bool
    reason: str | None = Field(None, description="Why the agent is not ready (null when ready).")
    recon: Readiness | None = Field(None, description="The recon service's readiness, when it answered.")
    sandbox: SandboxStatus | None = Field(None, description="The program sandbox's OS jail.")
    code_model: str
    answer_model: str


class SolveRequest(_Model):
    """JSON form of /v1/solve (multipart uses files `images` plus form fields of the same names)."""

    question: str = Field(..., min_length=1, max_length=10_000)
    images: list[str] | None = Field(None, description="Images in order, base64 or data URLs.")
    scene_id: str | None = Field(
        None,
        pattern=SCENE_ID_PATTERN,
        description="A scene already uploaded to the recon service (24 hex characters).",
    )
    backbone: str | None = None
    max_repairs: Annotated[int, Field(ge=0, le=5)] | None = None


class AttemptRecord(_Model):
    program: str | None = Field(..., description="The program as checked and run (demo code dropped).")
    error: str | None
    reply: str | None = Field(None, description="The code model's raw reply (None for the offline planner).")
    latency_ms: float
    error_kind: str | None = Field(
        None,
        description="no_program, too_long, repeated (not run again), or the sandbox's kind (rejected, ...).",
    )
    dropped: list[str] = Field(
        default_factory=list, description="Top-level demo code removed from the reply."
    )
    temperature: float | None = None
    prompt_tokens: int | None = None
    completion_tokens: int | None = None


class ClueView(_Model):
    """Where one clue image came from: a view rendered from a pose, or an input photo."""

    source: Literal["rendered", "input"]
    input_view: int | None = Field(None, ge=1, description="The input view (1-based), when source is input.")
    extrinsic: Matrix | None = Field(
        None, description="3x4 camera-from-world it was rendered from (or the input camera's pose)."
    )
    width: int
    height: int


class Clue(_Model):
    text: str | None = None
    images: list[str] = Field(default_factory=list, description="Rendered views as base64 PNG.")
    views: list[ClueView] = Field(
        default_factory=list, description="One per image, in the same order: where it came from."
    )
    notes: list[str] = Field(
        default_factory=list, description="What the service noticed about the clue, e.g. an empty view."
    )


class SolveTimings(_Model):
    reconstruction_ms: float = Field(..., description="Reconstructing the scene (or reading the cache).")
    codegen_ms: float
    execution_ms: float
    answering_ms: float
    total_ms: float


class ErrorBody(_Model):
    """Every error response of both services."""

    detail: str = Field(..., description="What went wrong, for a person to read.")
    attempts: list[AttemptRecord] | None = Field(
        None, description="/v1/solve only, when the infrastructure failed mid-solve: the attempts so far."
    )


class TokenCounts(_Model):
    code_prompt: int = 0
    code_completion: int = 0
    answer_prompt: int = 0
    answer_completion: int = 0


# ---- the steps of one solve: scene -> reconstruction -> program -> execution (repairs) -> answer ----

SolveStage = Literal["upload", "reconstruction", "program", "execution", "answer"]


class StepRecord(_Model):
    """One step of a solve: when it ran, and why it failed when it did (the solve went on).

    Fields marked `exclude` carry what the next stage needs (photos, rendered views) inside the agent;
    they are not sent (the response has the clue's images once, in `clue`).
    """

    stage: SolveStage = Field(..., description="The stage of the event stream this step belongs to.")
    started_ms: float = Field(0.0, description="When the step started, since the solve began.")
    duration_ms: float = 0.0
    error: str | None = Field(None, description="Why the step failed; null when it did its job.")


class SceneStep(StepRecord):
    """The photos uploaded to the recon service (or an existing scene looked up)."""

    kind: Literal["scene"] = "scene"
    stage: Literal["upload"] = "upload"
    uploaded_images: int = Field(0, description="Images sent with the request; 0 for an existing scene.")
    scene_id: str | None = None
    num_images: int = 0
    input_pngs: list[bytes] = Field(default_factory=list, exclude=True, repr=False)


class ReconstructionStep(StepRecord):
    """The scene reconstructed (or read from the cache); a 422 of the backbone is its `error`."""

    kind: Literal["reconstruction"] = "reconstruction"
    stage: Literal["reconstruction"] = "reconstruction"
    requested_backbone: str | None = Field(None, description="Null: the service's default backbone.")
    backbone: str | None = None
    views_placed: int = 0
    num_views: int = 0
    num_points: int = 0
    cached: bool = False
    cameras: list[CameraInfo] = Field(default_factory=list, exclude=True, repr=False)


ProgramSource = Literal["model", "repaired-model", "planner"]


class ProgramStep(StepRecord):
    """One program asked for: a code model's reply (first or a repair), or the offline planner's."""

    kind: Literal["program"] = "program"
    stage: Literal["program"] = "program"
    attempt: int = Field(..., description="1-based, as in the response's `attempts`.")
    author: str = Field(..., description="The code model's name, or 'offline-planner'.")
    repairs: int | None = Field(
        None,
        description="The failed execution (its `run`) this request asks to repair; null for the first "
        "request and after a reply that had no program to run.",
    )
    program: str | None = Field(
        None, description="The program handed to the sandbox; null when none was (see error_kind)."
    )
    fallback: bool = Field(
        False, description="The offline planner's program, asked for after the code model's attempts failed."
    )
    error_kind: str | None = Field(
        None, description="no_program, too_long, repeated, model (the model failed), unplannable."
    )


class ExecutionStep(StepRecord):
    """One run of a program in the sandbox, and whether its output is evidence."""

    kind: Literal["execution"] = "execution"
    stage: Literal["execution"] = "execution"
    run: int = Field(..., description="1-based count of sandbox runs in this solve.")
    attempt: int = Field(..., description="The program's attempt (see ProgramStep.attempt).")
    ok: bool = False
    error_kind: str | None = Field(
        None, description="The sandbox's kind (rejected, exception, ...) or not_evidence."
    )
    clue_text: str | None = None
    clue_images: int = Field(0, description="How many images the program returned.")
    clue_pngs: list[bytes] = Field(default_factory=list, exclude=True, repr=False)


class AnswerStep(StepRecord):
    """The answer chosen from the clue, or from the photos alone; `error` says why there is none."""

    kind: Literal["answer"] = "answer"
    stage: Literal["answer"] = "answer"
    answerer: str | None = Field(None, description="What was asked; null when nothing could answer.")
    from_photos: bool = Field(False, description="Answered from the photos alone (no program ran).")
    answered_by: str | None = Field(
        None, description="What the response names as `answer_model` (e.g. '<model> (text only)')."
    )
    answer_format: Literal["choice", "free_form"] = Field(
        "choice", description="'choice': `answer` is an option letter; 'free_form': words (no options)."
    )
    answer: str | None = None
    method: str | None = None
    reasoning: str = ""
    prompt_tokens: int = 0
    completion_tokens: int = 0
    reading: str | None = Field(
        None,
        description='How a camera question was read, e.g. "read as: camera rotation from image 1 to '
        "image 3, in image 1's axes\"; null for other questions.",
    )


SolveStep = Annotated[
    SceneStep | ReconstructionStep | ProgramStep | ExecutionStep | AnswerStep, Field(discriminator="kind")
]


class SolveResponse(_Model):
    answer: str | None = Field(
        ...,
        description="The option letter (answer_format 'choice'), the answer in words (answer_format "
        "'free_form'), or null when no honest answer exists.",
    )
    answer_format: Literal["choice", "free_form"] = Field(
        "choice",
        description="'choice' when the question has lettered options (A. ... B. ...); 'free_form' when it "
        "has none, so `answer` is free text (a model's words, or the offline answerer's reading of the "
        "camera-motion sentence).",
    )
    answer_reason: str | None = Field(None, description="Why answer is null.")
    reasoning: str
    program: str | None = Field(..., description="The exact code that ran.")
    clue: Clue
    attempts: list[AttemptRecord]
    scene_id: str
    backbone: str
    code_model: str = Field(
        ...,
        description="What wrote the program: the model's name, 'offline-planner', or "
        "'offline-planner (fallback: <model> failed)'.",
    )
    code_model_fallback: str | None = Field(
        None,
        description="Why the configured code model did not write the program (it failed; the planner did).",
    )
    program_source: ProgramSource | None = Field(
        None,
        description="Who wrote the program that ran: 'model' (the code model's first program), "
        "'repaired-model' (the code model's, after repairs), 'planner' (the offline planner: no code "
        "model, or after the model's attempts failed; those stay in `attempts`); null when none ran.",
    )
    answer_model: str = Field(..., description="What answered: model name, or 'offline-answerer'.")
    answer_method: str | None = Field(
        None,
        description="model_json, model_text, text_model (a text-only model read a text clue), offline_text.",
    )
    tokens: TokenCounts = Field(default_factory=TokenCounts, description="Model tokens spent, per stage.")
    fallback: Literal["images_only"] | None = Field(
        None,
        description="'images_only': no program ran (the backbone could not reconstruct, or no program "
        "could be written or run), so the answer model answered from the photos alone.",
    )
    fallback_reason: str | None = Field(None, description="Why the fallback was taken.")
    intent: QuestionIntent | None = Field(
        None, description="The question as parsed once: setting, family, asked view, view pair, steps."
    )
    reading: QuestionReading | None = Field(
        None,
        description="The question's typed reading, made once and used by every stage: the ordered "
        "pair of views, the quantity asked (translation, rotation, position, motion, still, "
        "object_relation, other), the frame, each option as a typed claim, where each slot came "
        "from and whether it is certain, `abstain_reason` (why no answer may be given), `summary`.",
    )
    timings: SolveTimings
    steps: list[SolveStep] = Field(
        default_factory=list,
        description="The solve's steps in order (scene, reconstruction, program, execution, answer): "
        "what each got and produced, its timing, and why it failed. The event stream is made from them.",
    )


# ---- progress of one solve (POST /v1/solve with Accept: text/event-stream) ---------------


class StageEvent(_Model):
    """A stage of the solve started, finished or failed (SSE event name: `stage`)."""

    type: Literal["stage"] = "stage"
    stage: SolveStage
    state: Literal["started", "done", "failed"]
    detail: str = ""
    elapsed_ms: float = Field(..., description="Since the solve began.")


class ResultEvent(_Model):
    """The last event of a successful solve (SSE event name: `result`)."""

    type: Literal["result"] = "result"
    result: SolveResponse


class ErrorEvent(_Model):
    """The last event of a failed solve (SSE event name: `error`): the status /v1/solve would return."""

    type: Literal["error"] = "error"
    status_code: int
    detail: str
    stage: SolveStage | None = Field(None, description="The stage that was running, if any.")
    attempts: list[AttemptRecord] | None = Field(
        None, description="When the infrastructure failed while a program ran: the attempts so far."
    )


SolveEvent = Annotated[StageEvent | ResultEvent | ErrorEvent, Field(discriminator="type")]


# ---- route plans (agent: POST /v1/route) ---------------------------------------------------

Point3 = Annotated[list[float], Field(min_length=3, max_length=3)]


class GoalPixel(_Model):
    view: int = Field(..., ge=1, description="1-based view, as on the page.")
    u: float = Field(..., description="Column, pixel centres at integers (OpenCV).")
    v: float = Field(..., description="Row.")


class RouteGoal(_Model):
    """Exactly one of: a pixel of a view, a world point, or a point in the start camera's frame."""

    pixel: GoalPixel | None = None
    point_world: Point3 | None = None
    point_start_camera: Point3 | None = Field(None, description="OpenCV axes: x right, y down, z forward.")


class RobotSpec(_Model):
    radius: float = Field(0.25, gt=0, le=5, description="Metres.")
    height: float = Field(0.5, gt=0, le=5, description="Top of the body above the floor, metres.")
    floor_clearance: float = Field(
        0.05, ge=0, le=2, description="Bottom of the body: anything lower is driven over, metres."
    )
    camera_height_m: float | None = Field(
        None,
        gt=0,
        le=10,
        description="The robot's camera above the floor, metres: makes a scene-unit reconstruction metric "
        "(scaled from the floor plane under the start view); with a metric one, checked against it.",
    )


class RouteRequest(_Model):
    """JSON form of /v1/route (multipart: files `images` and `depths`, JSON text fields otherwise)."""

    images: list[str] | None = Field(None, description="Images in order, base64 or data URLs.")
    scene_id: str | None = Field(None, pattern=SCENE_ID_PATTERN)
    extrinsics: list[Matrix] | None = Field(None, description="Per view 3x4 camera-from-world (with depths).")
    intrinsics: list[Matrix | None] | None = Field(None, description="Per view 3x3 pixel intrinsics.")
    backbone: str | None = Field(
        None,
        description="Wins when given; else an upload with depths runs posed-rgbd, and a scene_id is "
        "reconstructed as it was uploaded (posed-rgbd for posed RGB-D). The response's backbone says "
        "which ran.",
    )
    start_view: int = Field(1, ge=1, description="1-based view whose camera stands above the robot's start.")
    goal: RouteGoal
    robot: RobotSpec = Field(default_factory=RobotSpec)


class RouteStep(_Model):
    turn_degrees: float = Field(
        ..., description="Turn in place about up first, degrees; + = left (counter-clockwise from above)."
    )
    move: float = Field(..., description="Then drive forward this far, in `units` (metres or scene units).")
    unseen_m: float = Field(
        0.0, description="Of the move, this much crosses floor no view saw (move's units)."
    )


class UnseenStretch(_Model):
    step: int = Field(..., ge=1, description="1-based step whose move crosses it.")
    start_world: list[float]
    end_world: list[float]
    length: float = Field(..., description="In the moves' units.")


class LookNext(_Model):
    """Where to take the next photo when no photo shows a way (an ``unseen_space`` refusal)."""

    stand_world: list[float] = Field(..., description="Stand here (on the floor, world coordinates).")
    face_world: list[float] = Field(
        ..., description="Face this point: where the likeliest way enters space no view looked into."
    )
    steps: list[RouteStep] = Field(
        ..., description="From the start, over floor the photos show; the last turns to face, moving 0."
    )
    sentences: list[str]


class RouteResponse(_Model):
    scene_id: str
    backbone: str
    reachable: bool
    reason: str | None = Field(
        None, description="Why no route was planned (which gap and how wide, enclosed)."
    )
    refusal: str | None = Field(
        None,
        description="narrow_gap, enclosed, start_blocked, goal_too_close, goal_unseen (outside the map), "
        "unseen_space (every way passes where no view looked: see look_next)",
    )
    turn_convention: Literal["left-positive"] = "left-positive"
    steps: list[RouteStep]
    sentences: list[str]
    path_world: list[list[float]]
    path_start_camera: list[list[float]]
    clearance: float | None = Field(
        None, description="Smallest gap between the robot and an obstacle, in `units`."
    )
    length: float | None = Field(..., description="The route's length, in `units`.")
    straight_line: float | None = Field(..., description="Start to goal in a straight line, in `units`.")
    units: Literal["metres", "scene units"] = Field(
        ..., description="The unit of every length here: metres when the reconstruction is metric."
    )
    metres_per_unit: float | None = Field(
        None, description="1 when metric; otherwise the estimate from an assumed 1.5 m camera height."
    )
    scale_from: Literal["metric reconstruction", "camera height", "assumed camera height"] | None = None
    floor_residual_m: float | None = Field(
        None, description="RMS of the floor points about the fitted floor plane near the start, metres."
    )
    scale_check: float | None = Field(
        None,
        description="Metric reconstruction and a camera height: the reconstructed height over the given.",
    )
    unseen_m: float | None = Field(
        None, description="Of the length, this much crosses floor no view saw (assumed free: go slowly)."
    )
    unseen_stretches: list[UnseenStretch] = Field(default_factory=list)
    narrowest_passage_m: float | None = Field(
        None, description="narrow_gap: the passage's width between the seen obstacles on both sides."
    )
    look_next: LookNext | None = Field(
        None,
        description="unseen_space: where to stand and which way to face for the photo that may show "
        "the way (then plan again with it as the start view).",
    )
    start_world: list[float] | None
    goal_world: list[float] | None = Field(None, description="The goal projected on the floor.")
    goal_located: list[float] | None = Field(None, description="The goal's world point (for a pixel goal).")
    up: list[float] | None
    warnings: list[str]
