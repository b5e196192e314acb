"""Learning-from-demonstration representations with one interface.

Every class learns with ``fit(demos)`` (Demonstrations with a ``"position"``
stream, or arrays ``(n_steps, n_dims)``) and generates with
``reproduce(constraints=None, n_steps=None)``, returning a
:class:`~skillbank.Demonstration` that meets the
:class:`~skillbank.Constraints` (start, goal, via-points; obstacles by
post-editing with Laplacian trajectory editing, see
:class:`Representation`). :data:`REPRESENTATIONS` maps the method names of
``reuse`` and the command line to these classes.

- :class:`LaplacianEditor`: one demonstration, edited as it is (LTE); avoids obstacles itself.
- :class:`JerkAccuracy`: one demonstration; accuracy-smoothness trade-off.
- :class:`ProMP`: several demonstrations; Gaussian over trajectories.
- :class:`ElasticMap`: one or more; elastic polyline fitted by EM.
- :class:`DMP`: one (or an average); start and goal only.

Examples
--------
>>> import numpy as np
>>> from skillbank import Constraints
>>> from skillbank.representations import JerkAccuracy
>>> t = np.linspace(0, 1, 100)
>>> model = JerkAccuracy().fit(np.column_stack([t, t**2]))
>>> model.reproduce(Constraints(goal=[1.0, 1.2]))["position"][-1].tolist()
[1.0, 1.2]
"""

from ._base import Representation
from ._dmp import DMP
from ._elastic_map import ElasticMap
from ._jerk_accuracy import JerkAccuracy
from ._lte import LaplacianEditor
from ._promp import ProMP
from ._registry import REPRESENTATIONS, fit_reproduce, representation

__all__ = [
    "Representation", "LaplacianEditor", "JerkAccuracy", "ProMP", "ElasticMap", "DMP", "REPRESENTATIONS",
    "representation", "fit_reproduce",
]
