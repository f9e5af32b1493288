"""Real processes for tests: re-exported from shared.local.services (the CLI and benches use it too)."""

from shared.local.services import (  # noqa: F401
    REPO_ROOT,
    RedisServer,
    ServiceProcess,
    free_port,
    redis_answers,
    running_service,
    start_redis,
    start_service,
)
