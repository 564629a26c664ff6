"""Controllers: PI wheel-speed loops, MPC pose controllers, and the protocols the closed loop relies on."""

from agvctl.controllers.base import PoseCommand, PoseController, WheelSpeedController
from agvctl.controllers.baselines.feedforward import FeedForwardPoseController
from agvctl.controllers.pi.gains_file import PISettings, load_gains
from agvctl.controllers.pi.options import PIGains
from agvctl.controllers.pi.tuning import LoopMargins, TuningResult, TuningSpec, design_pi
from agvctl.controllers.pi.wheel_loop import PIWheelController

__all__ = ["FeedForwardPoseController", "PoseCommand", "PoseController", "WheelSpeedController"]
__all__ += ["LoopMargins", "PIGains", "PISettings", "PIWheelController", "TuningResult", "TuningSpec"]
__all__ += ["design_pi", "load_gains"]
