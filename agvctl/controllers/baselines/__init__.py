"""Baseline pose controllers, the yardsticks the MPC is compared with and falls back on.

* :mod:`~agvctl.controllers.baselines.ramsete` — WPILib's Ramsete unicycle tracking law.
* :mod:`~agvctl.controllers.baselines.ltv_lqr` — WPILib's LTV unicycle controller (an LQR gain schedule).
* :mod:`~agvctl.controllers.baselines.unicycle` — what the two share: the robot-frame error and the wheel speeds.
* :mod:`~agvctl.controllers.baselines.feedforward` — the reference's own wheel speeds, no feedback.
"""

from agvctl.controllers.baselines.feedforward import FeedForwardPoseController
from agvctl.controllers.baselines.ltv_lqr import LtvLqrConfig, LtvLqrController
from agvctl.controllers.baselines.ramsete import RamseteConfig, RamseteController

__all__ = [
    "FeedForwardPoseController",
    "LtvLqrConfig",
    "LtvLqrController",
    "RamseteConfig",
    "RamseteController",
]
