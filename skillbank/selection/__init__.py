"""Selection of reusable primitives: adapt stored primitives to a new task, rank them, reproduce.

The paper's "Selection of Reusable Primitives": every candidate is warped to
the task's constraints with Laplacian trajectory editing, candidates that
still collide or miss a constraint are dropped, the rest are ranked by curve
length, and the best ones train a learning-from-demonstration representation
that produces the new trajectory. The reproduction is then completed into
something a robot executes (:func:`make_executable`): the orientation adapted
to orientation constraints, the gripper and other recorded streams carried
over, time from 0 within velocity and acceleration limits, and joints by
inverse kinematics for a robot model.

Examples
--------
>>> import numpy as np
>>> from skillbank import Constraints
>>> from skillbank.selection import reuse
>>> s = np.linspace(0.0, 1.0, 100)
>>> prims = [np.column_stack([s, a * np.sin(np.pi * s)]) for a in (0.5, 0.2, 0.3)]
>>> res = reuse(prims, Constraints(goal=[1.2, 0.1]), method="ja", ids=["a", "b", "c"])
>>> res.used, res.trajectory["position"][-1].round(6).tolist()
(['b'], [1.2, 0.1])
"""

from ._candidates import RANKINGS, SHORTLIST, Candidate, Selection, select_candidates
from ._clear import MAX_REPAIRS, keep_clear, shift_near
from ._execution import (
    DISCRETE_STREAMS,
    LIMITS,
    Executable,
    executable_dict,
    make_executable,
    peak_rates,
    retime,
)
from ._relations import Relation, acted_on, compose, describe_relation, object_streams
from ._reuse import METHODS, ReuseResult, reproduce_selection, reuse

__all__ = [
    "keep_clear", "MAX_REPAIRS", "shift_near", "Relation", "acted_on", "compose", "object_streams",
    "describe_relation",
    "reuse", "ReuseResult", "select_candidates", "reproduce_selection", "Selection", "Candidate",
    "METHODS", "RANKINGS", "SHORTLIST", "make_executable", "Executable", "retime", "peak_rates", "LIMITS",
    "DISCRETE_STREAMS", "executable_dict",
]
