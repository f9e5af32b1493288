"""The reconstruction service's HTTP routes, one router per resource.

| module | routes |
| --- | --- |
| `health.py` | `GET /healthz`, `GET /readyz` |
| `backbones.py` | `GET /v1/backbones` |
| `scenes.py` | `POST /v1/scenes`, `GET /v1/scenes/{id}`, `GET /v1/scenes/{id}/images/{index}` |
| `reconstructions.py` | `POST /v1/scenes/{id}/reconstruct`, `GET .../reconstruction`, `GET .../points` |
| `render.py` | `POST /v1/render` |
| `camera_motion.py` | `POST /v1/camera-motion` |

Routes reach the service through the dependencies in `dependencies.py`; `services/recon/app.py`
builds the service and includes `ROUTERS`. A new endpoint goes into the router of its resource
(or a new module listed here), and `tests/test_openapi_contract.py` must provoke each status code
it documents.
"""

from services.recon.routes import backbones, camera_motion, health, reconstructions, render, scenes

ROUTERS = (
    backbones.router,
    health.router,
    scenes.router,
    reconstructions.router,
    render.router,
    camera_motion.router,
)
