"""skillbank: turn robot demonstrations into a reusable library of motion primitives.

The top level holds the data model and task constraints (from
:mod:`skillbank.core`) and the pipeline entry point :class:`Library`; the
sub-packages hold the rest, one layer each (``docs/architecture.md``).
``Library`` is imported on first use, so ``import skillbank`` stays as light
as numpy.

Examples
--------
>>> import numpy as np
>>> import skillbank
>>> t = np.linspace(0.0, 1.0, 200)
>>> demo = skillbank.Demonstration(t, {"position": np.column_stack([t, t**2])})
>>> demo.n_steps
200
"""

import importlib

from .core import Box, Constraints, Demonstration, Obstacle, Sphere, ViaPoint, __version__

__all__ = ["Demonstration", "Constraints", "ViaPoint", "Obstacle", "Sphere", "Box", "Library", "__version__"]

_LAZY = {"Library": "skillbank.pipeline"}


def __getattr__(name):
    # The pipeline pulls in scikit-learn and scipy; import it when it is first asked for.
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'skillbank' has no attribute {name!r}")
