"""All configuration, in one place, read from the environment (and an optional `.env` file).

Every variable is documented in README.md ("Configuration"). Names are PYSPATIAL_* except
REDIS_URL, which follows the common convention.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import AliasChoices, Field, SecretStr, field_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

DEFAULT_DATA_DIR = Path.home() / ".cache" / "pyspatial"
DEFAULT_RECON_PORT = 8001
DEFAULT_AGENT_PORT = 8000
# The agent's recon timeout must outlast the longest a recon request may wait for a lease or a
# queue slot plus one reconstruction; tests/test_recon_runtime.py checks the defaults agree.
RECON_WAIT_S = 300.0


class _Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="PYSPATIAL_", env_file=".env", extra="ignore")


class AccessSettings(_Settings):
    """Access control of one service (both have these; shared/wire/access.py applies them to /v1/)."""

    api_keys: SecretStr | None = Field(
        None,
        description="Comma-separated bearer keys accepted on /v1/, each `tenant:key` (a plain key: the "
        "tenant `default`; `*:key`: a service key); no authentication when unset.",
    )
    rate_limit_per_minute: int = Field(
        0, ge=0, description="Requests per minute per key (per client address without keys); 0 = off."
    )
    rate_limit_burst: int = Field(20, ge=1, description="Requests a key may send at once before 429.")
    cors_origins: str = Field(
        "", description="Comma-separated origins allowed by CORS (`*` for any); CORS is off when empty."
    )
    docs_enabled: bool = Field(True, description="Serve /docs, /redoc and /openapi.json.")
    trusted_proxies: str = Field(
        "127.0.0.1",
        description="Comma-separated addresses or networks (CIDR) of the proxies whose X-Forwarded-For "
        "is believed (nginx in compose, the ingress in k8s); `*` trusts any; others' is ignored.",
    )
    auth_failures_per_minute: int = Field(
        10, ge=0, description="Failed authentications per client address per minute before 429; 0 = off."
    )


class ServiceSettings(AccessSettings):
    """What both services enforce alike: the drain on SIGTERM and the limits of an upload."""

    drain_s: float = Field(20.0, gt=0, description="On SIGTERM: longest wait for running work before exit.")
    max_images: int = Field(32, ge=1, le=256, description="Most images in one upload.")
    max_image_bytes: int = Field(25 * 2**20, ge=1024, description="Largest encoded image file.")
    max_image_pixels: int = Field(40_000_000, ge=1, description="Largest decoded image (width x height).")
    max_request_bytes: int = Field(300 * 2**20, ge=1024, description="Largest upload request body.")
    max_request_pixels: int = Field(
        400_000_000, ge=1, description="Most decoded pixels in one upload (all images together)."
    )


class ReconSettings(ServiceSettings):
    backbone: str = Field(
        "classical",
        description="Default backbone: classical, posed-rgbd, vggt, pi3, pi3x, or auto (Pi3X when its "
        "weights are present, then VGGT, then classical).",
    )
    vggt_checkpoint: Path | None = Field(
        None, description="VGGT-1B checkpoint (.pt or .safetensors); when unset, the hub cache's `model.pt`."
    )
    vggt_config: Path | None = Field(None, description="JSON model config; VGGT-1B sizes when unset.")
    pi3_checkpoint: Path | None = Field(
        None, description="Pi3 checkpoint; when unset, the hub cache's `yyfz233/Pi3` `model.safetensors`."
    )
    pi3_config: Path | None = Field(
        None, description="Pi3 config (fixture JSON format); full size when unset."
    )
    pi3x_checkpoint: Path | None = Field(
        None, description="Pi3X checkpoint; when unset, the hub cache's `yyfz233/Pi3X` `model.safetensors`."
    )
    pi3x_config: Path | None = Field(
        None, description="Pi3X config (fixture JSON format); full size when unset."
    )
    weights_revision: str = Field(
        "main", description="Hub revision (branch, tag or commit) whose pulled checkpoints the service uses."
    )
    pi3_max_views: int = Field(
        64, ge=1, description="Most views Pi3 / Pi3X take in one scene (more is a 413 before the model runs)."
    )
    pi3_pixel_limit: int = Field(
        255_000, ge=14 * 14, description="Pixels per view Pi3 / Pi3X resize to (the published 255,000)."
    )
    device: str | None = Field(None, description="torch device for learned backbones; cuda when present.")
    redis_url: str | None = Field(
        None,
        validation_alias=AliasChoices("REDIS_URL", "PYSPATIAL_REDIS_URL"),
        description="Redis for the reconstruction cache; an in-process cache is used when unset.",
    )
    cache_namespace: str = Field("default", description="Prefix of cache keys (separates deployments).")
    cache_ttl_s: int = Field(7 * 24 * 3600, ge=1, description="Lifetime of cached reconstructions.")
    memory_cache_mb: int = Field(512, ge=1, description="In-process cache size (also the Redis-down buffer).")
    data_dir: Path = Field(DEFAULT_DATA_DIR, description="Where uploaded scenes are stored.")
    store_dir: Path | None = Field(
        None,
        description="Durable store of record for scenes and reconstructions, on a volume every replica "
        "mounts (Redis is then only a cache); unset: the data dir and Redis only.",
    )
    scene_id_secret: SecretStr | None = Field(
        None,
        description="Secret under which other tenants' scene ids are derived; unset: a random one kept in "
        "the store (or data dir). Keep it: a new one gives the same uploads new ids.",
    )
    store_max_age_days: float = Field(
        0.0, ge=0, description="The store's GC removes scenes unused for this long; 0 = no age limit."
    )
    store_max_gb: float = Field(
        0.0, ge=0, description="The store's GC removes least recently used scenes above this size; 0 = off."
    )
    store_gc_interval_s: float = Field(
        3600.0, gt=0, description="How often each replica runs the store's GC (when a limit is set)."
    )
    max_render_side: int = Field(2048, ge=16, description="Largest rendered image side.")
    reconstruct_workers: int = Field(1, ge=1, description="Reconstructions run at once (CPU/GPU bound).")
    reconstruct_lease_s: int = Field(
        15,
        ge=3,
        description="Lifetime of a reconstruction lease; renewed every third of it while the work runs, "
        "so a crashed replica blocks a scene for at most this long.",
    )
    reconstruct_wait_s: float = Field(
        RECON_WAIT_S,
        gt=0,
        description="Longest a request waits for a worker or another replica's reconstruction (then 503).",
    )
    max_queued_reconstructions: int = Field(
        16, ge=1, description="Reconstructions waiting for a worker; more get 503 with Retry-After."
    )
    shared_scenes: bool = Field(
        True, description="With REDIS_URL: publish scenes to Redis so every replica serves every scene."
    )
    scene_ttl_s: int = Field(30 * 24 * 3600, ge=60, description="Lifetime of a shared scene in Redis.")
    max_decoding_pixels: int = Field(
        800_000_000, ge=1, description="Most pixels decoded at once; more uploads get 503 + Retry-After."
    )
    decode_processes: int = Field(
        2, ge=0, description="Processes that decode uploaded images (0: threads of the service process)."
    )
    max_motion_pairs: int = Field(1024, ge=1, description="Most view pairs in one camera-motion request.")


class AgentSettings(ServiceSettings):
    recon_url: str = Field(f"http://127.0.0.1:{DEFAULT_RECON_PORT}", description="Reconstruction service.")
    recon_api_key: SecretStr | None = Field(
        None,
        description="Bearer key the agent sends to the recon service (one of recon's API keys); given as "
        "recon lists it, `*:key` (a service key), the agent sends `key`.",
    )
    readiness_timeout_s: float = Field(
        5.0, gt=0, description="Longest /readyz waits for the recon service before answering 503."
    )
    recon_timeout_s: float = Field(
        600.0, gt=0, description="Timeout of one call to the recon service (above its reconstruct_wait_s)."
    )
    recon_attempts: int = Field(
        3, ge=1, le=10, description="Tries of one recon call on a reset connection or a 502/503 (1 = none)."
    )
    recon_retry_window_s: float = Field(
        20.0, gt=0, description="No retry of a recon call starts later than this after its first try."
    )
    solve_deadline_s: float = Field(
        900.0,
        gt=0,
        description="A solve's recon calls, retries included, end by this long after the solve started.",
    )
    code_model: str | None = Field(None, description="Code model name; the offline planner when unset.")
    code_model_base_url: str | None = Field(None, description="OpenAI-compatible endpoint of the code model.")
    code_model_api_key: SecretStr | None = Field(None, description="API key of the code model endpoint.")
    code_model_text_only: bool = Field(
        False, description="The code model takes plain text only: string content, no images."
    )
    code_model_max_tokens: int = Field(2048, ge=64, description="Longest reply of the code model (tokens).")
    answer_model: str | None = Field(
        None, description="Answer model (vision); the offline answerer when unset."
    )
    answer_model_text_only: bool = Field(
        False, description="The answer model takes text only: it answers text clues, never images."
    )
    answer_model_max_tokens: int = Field(
        1024, ge=16, description="Longest reply of the answer model (tokens)."
    )
    answer_model_base_url: str | None = Field(None, description="Endpoint of the answer model.")
    answer_model_api_key: SecretStr | None = Field(None, description="API key of the answer model endpoint.")
    model_timeout_s: float = Field(120.0, gt=0, description="Timeout of one model call.")
    model_max_retries: int = Field(3, ge=0, description="Retries on 429, 5xx and timeouts.")
    num_examples: int = Field(
        1, ge=0, le=6, description="In-context examples in the code prompt, most like the question first."
    )
    max_repairs: int = Field(2, ge=0, le=5, description="Self-repair rounds after a failed program.")
    max_reply_chars: int = Field(
        60_000,
        ge=1000,
        description="Longest code-model reply that is parsed; longer ones are refused unread.",
    )
    route_unseen_cost: float = Field(
        1.5,
        ge=1.0,
        le=100.0,
        description="Route plans: a metre over floor no view saw costs as much as this many over seen floor.",
    )
    sandbox_cpu_s: int = Field(20, ge=1, description="CPU seconds a program may use.")
    sandbox_wall_s: int = Field(
        120, ge=1, description="Wall-clock seconds a program may take, its tool calls included."
    )
    sandbox_memory_mb: int = Field(2048, ge=256, description="Address-space limit of a program.")
    sandbox_max_tool_calls: int = Field(
        32, ge=1, description="pySpatial tool calls one program may make (error kind tool_limit)."
    )
    sandbox_solve_cpu_s: int = Field(
        60,
        ge=1,
        description="CPU seconds all programs of one solve may use together, repairs included "
        "(error kind cpu_budget).",
    )
    sandbox_max_running: int = Field(4, ge=1, description="Program sandboxes running at once.")
    sandbox_max_waiting: int = Field(
        8, ge=0, description="Solves admitted beyond the running sandboxes; more get a 503 with Retry-After."
    )
    sandbox_retry_after_s: int = Field(
        5, ge=1, description="Retry-After of the 503 when the sandboxes are full."
    )
    sandbox_jail: Literal["required", "off"] = Field(
        "required",
        description="OS jail of generated programs (bubblewrap + seccomp); 'off' is an unsafe opt-out "
        "that runs them behind the Python-level checks only.",
    )
    sandbox_test_only_unchecked: bool = Field(
        False,
        description="TEST ONLY: skip the Python-level sandbox checks to prove the OS jail alone; "
        "refused unless the jail is active.",
    )

    @field_validator("recon_api_key", mode="after")
    @classmethod
    def _service_key_entry(cls, value: SecretStr | None) -> SecretStr | None:
        """One secret for both sides: recon lists `*:key` (a service key), the agent sends `key`."""
        if value is not None and value.get_secret_value().startswith("*:"):
            return SecretStr(value.get_secret_value()[2:])
        return value
