"""Trajectory planning: path files (segments with smooth joins, or waypoints) → time-optimal, jerk-limited
references within the wheel limits (Ruckig).

Offline::

    from agvctl.planning import load_path, plan
    ref = plan(load_path("trajectories/square.toml"), vehicle)   # a Reference
    ref.grid.x_m, ref.grid.wheel_speed_left_m_s                   # on the 40 ms control grid
    ref.sample(t_s)                                               # anywhere, vectorised
    ref.drawn_path_deviation_m                                    # how far it leaves the path the file draws

Online (velocity-command mode)::

    cmd = VelocityCommandPlanner.for_vehicle(vehicle)
    wheel_ref = cmd.step(speed_m_s=0.5, yaw_rate_rad_s=0.2)      # once per control period

Ruckig's intermediate waypoints are never used (the free edition computes them with a network service).
"""

from agvctl.planning.drawn import DrawnPath
from agvctl.planning.geometry import Pose, advance, path_end_pose, segment_end_pose
from agvctl.planning.limits import PhysicalLimitWarning, default_jerk_limit_m_s3, resolve_limits
from agvctl.planning.online import VelocityCommandPlanner, WheelCommand
from agvctl.planning.planner import plan, plan_file, plan_segments, plan_waypoints
from agvctl.planning.profile import JerkProfile, rest_to_rest
from agvctl.planning.reference import CSV_COLUMNS, Motion, Reference, ReferenceSamples
from agvctl.planning.spec import (
    BODY_PLAN_SHARE,
    DRAWN_PATH_TOLERANCE_M,
    ArcSegment,
    BodyLimits,
    HeadroomWarning,
    LineSegment,
    PathLimits,
    PathSpec,
    Segment,
    StartPose,
    TurnSegment,
    Waypoint,
    WheelLimits,
    load_path,
)

__all__ = [
    "BODY_PLAN_SHARE",
    "CSV_COLUMNS",
    "DRAWN_PATH_TOLERANCE_M",
    "ArcSegment",
    "BodyLimits",
    "DrawnPath",
    "JerkProfile",
    "LineSegment",
    "Motion",
    "PathLimits",
    "PathSpec",
    "HeadroomWarning",
    "PhysicalLimitWarning",
    "Pose",
    "Reference",
    "ReferenceSamples",
    "Segment",
    "StartPose",
    "TurnSegment",
    "VelocityCommandPlanner",
    "Waypoint",
    "WheelCommand",
    "WheelLimits",
    "advance",
    "default_jerk_limit_m_s3",
    "load_path",
    "path_end_pose",
    "plan",
    "plan_file",
    "plan_segments",
    "plan_waypoints",
    "resolve_limits",
    "rest_to_rest",
    "segment_end_pose",
]
