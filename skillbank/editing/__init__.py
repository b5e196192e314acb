"""Trajectory editing: Laplacian trajectory editing (LTE) under task constraints, and orientations.

Examples
--------
>>> import numpy as np
>>> from skillbank.core import Constraints, Sphere
>>> s = np.linspace(0.0, 1.0, 200)
>>> Y = np.column_stack([s, np.zeros_like(s)])
>>> res = lte(Y, Constraints(obstacles=[Sphere([0.5, 0.0], 0.1)]))
>>> bool(res.success), bool(res.collision)
(True, False)
"""

from ._laplacian import LaplacianSystem
from ._lte import EditResult, lte
from ._orientation import OrientationEdit, edit_orientation, relative_rotations

__all__ = [
    "lte", "EditResult", "LaplacianSystem", "edit_orientation", "OrientationEdit", "relative_rotations",
]
