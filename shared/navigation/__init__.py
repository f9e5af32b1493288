"""Route planning for a ground robot on a reconstruction: floor, occupancy, search, steps.

Layer like ``shared.geometry``: pure numpy, imports only ``geometry`` and itself.
"""

from shared.navigation.floor import Floor, estimate_floor
from shared.navigation.route import (
    TURN_CONVENTION,
    LocateResult,
    Robot,
    RoutePlan,
    locate,
    plan_route,
)

__all__ = [
    "TURN_CONVENTION",
    "Floor",
    "LocateResult",
    "Robot",
    "RoutePlan",
    "estimate_floor",
    "locate",
    "plan_route",
]
