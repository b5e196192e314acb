"""skillbank: turn robot demonstrations into a reusable library of motion primitives.

Examples
--------
>>> import numpy as np
>>> import skillbank
>>> t = np.linspace(0.0, 1.0, 200)
>>> demo = skillbank.Demonstration(t, {"position": np.column_stack([t, t**2])})
>>> demo.n_steps
200
"""

from ._constraints import Box, Constraints, Sphere, ViaPoint
from ._demonstration import Demonstration
from ._validation import check_array, check_time

__all__ = [
    "Demonstration", "Constraints", "ViaPoint", "Sphere", "Box", "check_array", "check_time", "__version__",
]
__version__ = "0.1.0"
