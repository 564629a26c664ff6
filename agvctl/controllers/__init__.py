"""Controllers: PI wheel-speed loops, MPC pose controllers, and the protocols the closed loop relies on."""

from agvctl.controllers.base import FeedForwardPoseController, PoseCommand, PoseController, WheelSpeedController

__all__ = ["FeedForwardPoseController", "PoseCommand", "PoseController", "WheelSpeedController"]
