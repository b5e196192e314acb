"""A start the arm can take: the configuration of a start given as a pose, clear of itself and the scene.

A scene's ``start`` given as a tool pose (or a position alone, the orientation
then the first step's reproduction's) leaves the joints open: the UR5e reaches a
pose on up to eight inverse-kinematics branches, an arm with a numerical
solver on as many as its seeds find. The start is the configuration nearest
the demonstration's recorded joints (else the robot's home) **that is clear of
the robot itself and of the scene** (its obstacles, table and workspace) with
the planning margin, checked by :func:`skillbank.robots.clearance` as every
step is. The scene's objects are left out, as at the start of the first step
(the robot may rest on them, and leaves them). With none clear, one line names
every branch (or seed) tried and why it failed. The choice itself is
:func:`skillbank.robots._start.clear_configurations`, which a reuse's start
with a robot takes too; this module says it in a scene's terms.
"""

from __future__ import annotations

import numpy as np

from ..robots._start import SEEDS, clear_configurations

__all__ = ["clear_starts", "SEEDS"]


def clear_starts(model, scene, position, quaternion, *, reference=None, names=(), margin, label):
    """The start configurations at a tool pose that are clear, nearest ``reference`` first.

    Parameters
    ----------
    model : RobotModel
    scene : Scene
        Its ``names`` obstacles, table and workspace are checked, and the robot itself.
    position : array-like of shape (3,)
    quaternion : array-like of shape (4,)
    reference : array-like of shape (n_joints,), optional
        The joints to start nearest (the demonstration's recorded ones); default the robot's home.
    names : sequence of str
        The scene's obstacles that apply.
    margin : float
        Metres every body keeps (the planning margin).
    label : callable
        ``label(other)``: how a message names what a body came near (an obstacle, the table, a body).

    Returns
    -------
    list of ndarray of shape (n_joints,)
        At least one.

    Raises
    ------
    ValueError
        One line naming every branch (or seed) tried and why it failed: unreachable (or the solver's
        reason), or the body and what it comes near.
    """
    # the one choice of a start (skillbank.robots.clear_configurations), said in the scene's terms
    clear, failed = clear_configurations(model, position, quaternion, reference=reference,
                                         obstacles={n: scene.obstacles[n] for n in names},
                                         table=getattr(scene, "table", None),
                                         workspace=getattr(scene, "workspace", None), margin=margin,
                                         label=label)
    if clear:
        return clear
    kind = "branch" if len(model.branch_names) > 1 else "seed"
    raise ValueError(f"start: robot {model.name} has no configuration at the start pose (tool point "
                     f"{np.round(np.asarray(position, float), 4).tolist()}) clear of itself and of the scene "
                     f"(clearance margin {margin * 1000:g} mm; --clearance sets it); every {kind} tried: "
                     + "; ".join(failed) + "; move the start, or give it as joints (start.joints)")
