"""The ranges of the pose controllers' numerical settings, each defined once with its reason.

A setting outside its range is refused with one line naming the key (``number(ge=…, le=…)``): such a value is a
typing error, not a tuning choice, and inside the solvers it overflows or stalls instead of failing clearly.
"""

from __future__ import annotations

__all__ = [
    "MAX_ACCEL_M_S2",
    "MAX_DISTANCE_M",
    "MAX_SCALE",
    "MAX_SOLVE_TIME_S",
    "MAX_WEIGHT",
    "MIN_ACCEL_M_S2",
    "MIN_SOLVE_TIME_S",
    "MIN_WHEEL_SPEED_M_S",
    "MAX_WHEEL_SPEED_M_S",
]

MAX_WEIGHT = 1e6
"""The largest cost weight: only ratios matter, the shipped ones span 10^-1 … 10^3, and a QP whose costs differ by
more than some 10^9 is beyond what OSQP resolves at its 10^-3 tolerance."""

MAX_SCALE = 1e3
"""The largest factor on a weight (terminal, turn in place): three orders above the shipped 1 and 3."""

MIN_WHEEL_SPEED_M_S = 1e-3
"""The smallest wheel-speed limit, 1 mm/s, as a path file's (:data:`~agvctl.planning.spec.MIN_LIMIT`): slower, a
metre takes a quarter of an hour and every setpoint is clipped to nothing."""

MAX_WHEEL_SPEED_M_S = 10.0
"""The largest wheel-speed limit, 10 m/s: ten times what any AGV's motors reach (the shipped one, 0.93 m/s)."""

MIN_ACCEL_M_S2 = 1e-3
"""The smallest acceleration limit, 1 mm/s²: the planner's smallest limit."""

MAX_ACCEL_M_S2 = 100.0
"""The largest acceleration limit, 100 m/s² (10 g): far past any wheel's grip (the shipped vehicle's eq-5 limit is
about 0.7 m/s²)."""

MIN_SOLVE_TIME_S = 1e-4
"""The shortest solver time budget, 0.1 ms: the shortest control period; no QP is set up in less."""

MAX_SOLVE_TIME_S = 10.0
"""The longest solver time budget, 10 s: 250 control periods at the shipped 40 ms, no longer a real-time budget."""

MAX_DISTANCE_M = 10.0
"""The largest tolerance, lag or deviation in metres: beyond the AGV's own size many times over."""
