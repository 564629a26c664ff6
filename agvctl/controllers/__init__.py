"""Controllers: PI wheel-speed loops, MPC pose controllers, and the protocols the closed loop relies on."""

from agvctl.controllers.base import FeedForwardPoseController, PoseCommand, PoseController, WheelSpeedController
from agvctl.controllers.pi import PIGains, PISettings, PIWheelController, load_gains
from agvctl.controllers.tuning import LoopMargins, TuningResult, TuningSpec, design_pi

__all__ = ["FeedForwardPoseController", "PoseCommand", "PoseController", "WheelSpeedController"]
__all__ += ["LoopMargins", "PIGains", "PISettings", "PIWheelController", "TuningResult", "TuningSpec"]
__all__ += ["design_pi", "load_gains"]
