"""Robot models: forward and inverse kinematics, joint limits and singularities, behind one interface.

:class:`RobotModel` is the interface (poses as position and scalar-last
quaternion; joints in kinematic-chain order); :class:`UR5e` is built in
(analytic); any other arm comes from its URDF or MJCF description
(:func:`load_description`, :class:`ChainModel`: numerical inverse
kinematics). :data:`ROBOTS` and :data:`DESCRIPTIONS` name the registered
models and :func:`robot_model` builds one by name or from a file.
:meth:`RobotModel.ik` follows one inverse-kinematics branch along a pose path
and raises :class:`KinematicsError` (a ``ValueError``) naming the first sample
it cannot follow and why.

Examples
--------
>>> import numpy as np
>>> from skillbank.robots import robot_model
>>> robot = robot_model("ur5e")
>>> position, quaternion = robot.fk([0.0, -1.2, 1.0, -1.4, -1.5, 0.3])
>>> robot.ik(position, quaternion, q_seed=[0.0, -1.2, 1.0, -1.4, -1.5, 0.3]).round(6).tolist()
[0.0, -1.2, 1.0, -1.4, -1.5, 0.3]
"""

from ._base import KinematicsError, RobotModel, Singularity
from ._bodies import GRIPPERS, PANDA_HAND, ROBOTIQ_2F85, Capsule, Gripper
from ._chain import ChainModel, KinematicChain
from ._clearance import Clearance, clearance
from ._clearing import CLEARANCE, clearing_move
from ._description import check_description_files, enclosing_capsule, load_description
from ._motion import MOTION_TIME_LIMIT, MotionPlan, MotionPlanningError, plan_motion
from ._points import PosePoint, pose_point, to_tool, tool_point
from ._registry import DESCRIPTIONS, ROBOTS, registered_name, robot_model
from ._time_law import STILL, TIME_LAWS, rate_ratio, time_law
from ._ur5e import UR5E_DH, UR5e

__all__ = ["RobotModel", "KinematicsError", "Singularity", "UR5e", "UR5E_DH", "ROBOTS", "DESCRIPTIONS",
           "robot_model", "registered_name", "ChainModel", "KinematicChain", "load_description",
           "check_description_files",
           "enclosing_capsule",
           "Capsule", "Gripper", "GRIPPERS", "ROBOTIQ_2F85", "PANDA_HAND", "Clearance", "clearance",
           "CLEARANCE", "clearing_move",
           "plan_motion", "MotionPlan", "MotionPlanningError", "MOTION_TIME_LIMIT",
           "PosePoint", "pose_point", "to_tool", "tool_point", "time_law", "rate_ratio", "TIME_LAWS", "STILL"]
