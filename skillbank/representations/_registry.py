"""The registry of representations: the one list of method names.

Selection, the pipeline and the command line read this mapping (and the class
attributes of :class:`~skillbank.representations.Representation`) instead of
keeping their own lists. Adding a method is one class and one line here.
"""

from __future__ import annotations

import warnings

from ._base import Representation, as_constraints
from ._dmp import DMP
from ._elastic_map import ElasticMap
from ._jerk_accuracy import JerkAccuracy
from ._lte import LaplacianEditor
from ._promp import ProMP

__all__ = ["REPRESENTATIONS", "representation", "fit_reproduce"]

#: Method name (as on the command line) -> representation class, in the order shown to users.
REPRESENTATIONS: dict[str, type[Representation]] = {
    "lte": LaplacianEditor,
    "ja": JerkAccuracy,
    "promp": ProMP,
    "elmap": ElasticMap,
    "dmp": DMP,
}


def representation(method: str) -> type[Representation]:
    """The class registered as ``method``; ValueError naming the known methods otherwise.

    Examples
    --------
    >>> representation("promp").__name__
    'ProMP'
    """
    try:
        return REPRESENTATIONS[method]
    except (KeyError, TypeError):
        raise ValueError(f"method: expected one of {list(REPRESENTATIONS)}, got {method!r}") from None


def fit_reproduce(method: str, demos, constraints=None, *, random_state=None, n_steps=None):
    """Learn ``method`` from ``demos`` and reproduce ``constraints``: ``(trajectory, collision, notes)``.

    Parameters
    ----------
    method : str
        A name in :data:`REPRESENTATIONS`.
    demos : list of Demonstration
        One for the single-demonstration methods (``lte``, ``ja``), one or more otherwise.
    constraints : Constraints, optional
    random_state : int, optional
        For the methods that sample.
    n_steps : int, optional
        Samples of the reproduction; default the representation's own.

    Returns
    -------
    trajectory : Demonstration
    collision : bool
        Whether the trajectory collides with an obstacle (:meth:`Constraints.collides`).
    notes : list of str
        Warnings raised on the way and the message of an edit that failed.

    Examples
    --------
    >>> import numpy as np
    >>> from skillbank import Constraints, Demonstration
    >>> demo = Demonstration.from_array(np.c_[np.linspace(0, 1, 50), np.zeros(50)])
    >>> out, collision, notes = fit_reproduce("lte", [demo], Constraints(goal=[1.0, 0.5]))
    >>> out["position"][-1].tolist(), collision
    ([1.0, 0.5], False)
    """
    cls = representation(method)
    demos = list(demos)
    if cls.single_demo and len(demos) != 1:
        many = [m for m, c in REPRESENTATIONS.items() if not c.single_demo]
        raise ValueError(f"input: method {method!r} ({cls.__name__}) adapts one demonstration, got "
                         f"{len(demos)}; use one of {many} for several")
    constraints = as_constraints(constraints)
    model = cls()
    if "random_state" in model.get_params():
        model.set_params(random_state=random_state)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)
        out = model.fit(demos).reproduce(constraints, n_steps=n_steps)
    notes = [str(w.message) for w in caught if issubclass(w.category, UserWarning)]
    edit = out.metadata.get("edit") or {}
    if cls.avoids_obstacles and not edit.get("success", True) and edit.get("message"):
        notes.append(str(edit["message"]))
    collision = bool(constraints.obstacles) and constraints.collides(out["position"])
    return out, collision, notes
