"""The agent service's HTTP routes, one router per resource.

| module | routes |
| --- | --- |
| `health.py` | `GET /healthz`, `GET /readyz` |
| `solve.py` | `POST /v1/solve` (JSON or multipart; plain or `Accept: text/event-stream`) |
| `web.py` | `GET /`, `GET /v1/scenes/{id}/points`, `GET /v1/scenes/{id}/reconstruction`, `/v1/backbones` |
| `route.py` | `POST /v1/route` (JSON or multipart; the plan of services/agent/route_plan.py) |
| `examples.py` | `GET /v1/examples`, `/v1/examples/{name}/images/{file}`, `.../thumbnail`, `/v1/example` |

Routes reach the pipeline and the settings through `dependencies.py`; `services/agent/app.py`
builds them, mounts the page's static files (`/web`) and includes `ROUTERS`. A new endpoint goes
into the router of its resource (or a new module listed here), and `tests/test_openapi_contract.py`
must provoke each status code it documents.
"""

from services.agent.routes import examples, health, route, solve, web

ROUTERS = (health.router, solve.router, route.router, web.router, examples.router)
