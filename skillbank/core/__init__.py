"""The core layer: the data model, input validation, task constraints and geometry.

Everything else in skillbank builds on these: :class:`Demonstration` (a time
base plus named streams), :class:`Constraints` (start, goal, via-points,
boundary velocities, obstacles), the :class:`Obstacle` shapes and their one
collision test, the geometry of sampled paths (the one resampler and the
path Laplacian) and of orientations (unit quaternions, SLERP, log / exp maps).
Nothing here imports another skillbank package.

Examples
--------
>>> import numpy as np
>>> from skillbank.core import Constraints, Demonstration, Sphere
>>> demo = Demonstration(np.linspace(0, 1, 3), {"position": [[0.0, 0.0], [0.5, 0.0], [1.0, 0.0]]})
>>> Constraints(obstacles=[Sphere([0.5, 0.0], 0.1)]).collides(demo["position"])
True
"""

from ._constraints import Constraints, ViaPoint
from ._demonstration import Demonstration
from ._joints import JOINT_KINDS, Joint, fit_joint
from ._obstacles import OBSTACLES, Box, Obstacle, Sphere, parse_obstacle
from ._paths import laplacian_matrix, neighbour_weights, resample, resample_many
from ._pose_point import POSE_OF, check_pose_of, state_pose_of
from ._rotations import (
    check_quaternions,
    continuous_quaternions,
    exp_map,
    log_map,
    matrix_to_quaternion,
    quaternion_angle,
    quaternion_to_matrix,
    slerp,
)
from ._version import __version__

__all__ = [
    "Demonstration", "Constraints", "ViaPoint", "Obstacle", "Sphere", "Box", "OBSTACLES", "parse_obstacle",
    "resample", "resample_many", "laplacian_matrix", "neighbour_weights", "__version__",
    "check_quaternions", "continuous_quaternions", "slerp", "log_map", "exp_map", "quaternion_angle",
    "quaternion_to_matrix", "matrix_to_quaternion", "POSE_OF", "check_pose_of", "state_pose_of",
    "Joint", "fit_joint", "JOINT_KINDS",
]
