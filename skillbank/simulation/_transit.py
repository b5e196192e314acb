"""Free-space moves of a robosuite arm planned in joint space, checked in the scene's own MuJoCo geometry.

robosuite's operational-space controller drives the tool along a path; the links behind it go where
inverse kinematics takes them, and on a far pick the forearm or a wrist link can sweep through a bin's
wall that the tool itself passes above. Here the free part of a commanded tool path is checked for the
whole arm, and where any body would come near the scene it is replaced by a planned joint path:

- :class:`~skillbank.simulation._arm_scene.ArmScene` is the arm in a private copy of the
  environment's MuJoCo model and data: the arm's joints set, a held object moved rigidly with the
  hand, MuJoCo's own collision detection on the geoms as they lie (every link, the gripper and the held
  object against everything that does not move with the hand, within :data:`MARGIN`), and damped
  least-squares inverse kinematics to the pose robosuite reports (``robot0_eef_pos`` /
  ``robot0_eef_quat``).
- :func:`plan_transit` searches with OMPL's RRTConnect (BSD-3-Clause, the planners MoveIt uses; extra
  ``plan``, set up by ``skillbank.robots._motion._ompl_path`` as for :func:`skillbank.robots.plan_motion`),
  every motion densified so that no joint turns more than :data:`JOINT_STEP` between checked states, then
  shortened by OMPL's simplifier, within a time bound; a failure is one line naming the start, the goal
  and the geom that blocks.
- :func:`free_move` takes a tool path and the span of it that is free space, follows it with inverse
  kinematics from the arm's joints and, only where that would bring a body within the margin, replaces
  the span by the planned path's tool poses (forward kinematics at the control rate, minimum-jerk in
  time, no joint faster than :data:`JOINT_SPEED`): what follows the span is driven as before, from where
  the planned move ends.
- :func:`free_span` says which part of an adapted segment is free space, from the data alone: after the
  part that leaves as the demonstration did (:data:`~skillbank.simulation._evaluate.LEAVE`), up to where
  the demonstration's own close-in is pinned (``CLOSE_IN``), or to the end for a segment that only
  leaves what the last one let go of.
"""

from __future__ import annotations

import time as _time

import numpy as np

from ..robots._motion import MotionPlanningError, _ompl, _ompl_path
from ._arm_scene import JOINT_STEP, MARGIN, ArmScene, _where
from ._robosuite import CONTROL_FREQ

__all__ = ["ArmScene", "plan_transit", "free_move", "free_span", "check_planner", "transit_timing",
           "PLANNER_CHOICES", "MARGIN"]

#: ``planner`` values: OMPL in the scene's MuJoCo geometry, or the tool paths as adapted.
PLANNER_CHOICES = ("ompl", "none")
#: Seconds a search may take.
TIME_LIMIT = 3.0
#: Seconds OMPL's simplifier may take.
SIMPLIFY_TIME = 0.5
#: rad/s: the fastest any joint turns in a driven planned move (peak of its minimum-jerk profile).
JOINT_SPEED = 0.8
#: m/s: the fastest the tool moves in it.
TOOL_SPEED = 0.25
#: Free spans shorter than this (m, tool) are driven as they are.
SHORTEST = 0.05


def check_planner(planner) -> str:
    """``planner`` checked: one of :data:`PLANNER_CHOICES`, and for ``"ompl"`` OMPL importable (before
    any episode runs, not at the first move that needs it).

    Examples
    --------
    >>> check_planner("none")
    'none'
    """
    if planner not in PLANNER_CHOICES:
        raise ValueError(f"planner: expected one of {list(PLANNER_CHOICES)}, got {planner!r}")
    if planner == "ompl":
        try:
            _ompl()
        except ImportError as error:
            raise ImportError(f"planner 'ompl': {error} (or planner 'none': free moves as adapted)") from None
    return planner


def transit_timing(per_episode_transits) -> dict:
    """``{"planned_transits", "planning_seconds_mean", "planning_seconds_max"}`` over the episodes' lists of
    planning seconds per planned transit.

    Examples
    --------
    >>> transit_timing([[0.5, 1.5], [], [1.0]])
    {'planned_transits': 3, 'planning_seconds_mean': 1.0, 'planning_seconds_max': 1.5}
    """
    every = [t for ts in per_episode_transits for t in ts]
    return {"planned_transits": len(every),
            "planning_seconds_mean": round(float(np.mean(every)), 4) if every else 0.0,
            "planning_seconds_max": round(float(np.max(every)), 4) if every else 0.0}


def plan_transit(scene, q_start, q_goal, *, time_limit=TIME_LIMIT, simplify_time=SIMPLIFY_TIME,
                 random_state=None):
    """A joint path from ``q_start`` to ``q_goal`` on which the arm, gripper and held object stay clear.

    Parameters
    ----------
    scene : ArmScene
    q_start, q_goal : array of shape (n_joints,)
    time_limit : float
        Seconds the search may take.
    simplify_time : float
        Seconds OMPL's simplifier may shorten the path.
    random_state : int, optional
        OMPL's seed: the same seed, the same path.

    Returns
    -------
    joints : ndarray of shape (n, n_joints)
        Waypoints from the start to the goal, joined by straight joint motions, each checked densely.
    seconds : float
        The search's and the simplification's time.

    Raises
    ------
    MotionPlanningError
        One line: the start or the goal not clear, or no path within the time limit, naming the start,
        the goal and the geoms that block.

    Examples
    --------
    >>> joints, seconds = plan_transit(ArmScene(env), q0, q1, random_state=0)  # doctest: +SKIP
    >>> joints[0].tolist() == list(q0)  # doctest: +SKIP
    True
    """
    q0, q1 = np.asarray(q_start, float), np.asarray(q_goal, float)
    for name, q in (("start", q0), ("goal", q1)):
        hit = scene.blocking(q)
        if hit is not None:
            raise MotionPlanningError(
                f"transit planning: the {name} {_where(q)} is not clear: {scene.describe(hit)} "
                f"(margin {scene.margin * 1000:g} mm)")
    tic = _time.perf_counter()
    if scene.motion_clear(q0, q1):
        return np.stack([q0, q1]), _time.perf_counter() - tic
    blocked = {}  # other geom -> [count, contact]

    def noted(hit):
        """True for no contact; a contact is kept to name what blocks the search."""
        if hit is None:
            return True
        seen = blocked.setdefault(hit[2], [0, hit])
        seen[0] += 1
        if hit[0] < seen[1][0]:
            seen[1] = hit
        return False

    def failure():
        if blocked:
            count, hit = max(blocked.values(), key=lambda v: v[0])
            why = f"blocked by {scene.names[hit[2]]} ({count} checks ran into it; {scene.describe(hit)})"
        else:
            why = "the search ran out of time"
        return (f"transit planning: no collision-free path from {_where(q0)} to {_where(q1)} found by OMPL "
                f"RRTConnect in {time_limit:g} s: {why} (margin {scene.margin * 1000:g} mm)")

    # the search stays within the limits and a quarter turn beyond the span of the two ends (no joint
    # winds round); each motion is checked densified in joint space, stopping at the first contact; a tree
    # grows by at most half a radian (short motions are cheap to check and rarely blocked)
    Q, _, _ = _ompl_path(scene.limits, q0[None], q1[None], lambda q: noted(scene.blocking(q)),
                         lambda a, b: noted(scene.motion_blocking(a, b)), failure=failure, span=np.pi / 2,
                         step=0.5, time_limit=time_limit, simplify_time=simplify_time,
                         random_state=random_state)
    for a, b in zip(Q[:-1], Q[1:], strict=True):  # never a silent success
        hit = scene.motion_blocking(a, b)
        if hit is not None:
            raise MotionPlanningError(
                f"transit planning: the path OMPL found from {_where(q0)} to {_where(q1)} is not clear: "
                f"{scene.describe(hit)}")
    return Q, _time.perf_counter() - tic


def _timed(scene, Q):
    """The tool poses (positions, quaternions) along joint waypoints ``Q`` at the control rate: minimum
    jerk over the path's joint length, no joint faster than :data:`JOINT_SPEED`, the tool than
    :data:`TOOL_SPEED` (peak speeds; a minimum-jerk profile peaks at 1.875 times its mean)."""
    fine = [Q[0]]
    for a, b in zip(Q[:-1], Q[1:], strict=True):
        k = max(1, int(np.ceil(np.abs(b - a).max() / (JOINT_STEP / 2))))
        fine.extend(a + s * (b - a) for s in np.linspace(0.0, 1.0, k + 1)[1:])
    fine = np.array(fine)
    along = np.r_[0.0, np.cumsum(np.abs(np.diff(fine, axis=0)).max(axis=1))]
    tools = np.array([scene.tool(q)[0] for q in fine])
    length = float(np.linalg.norm(np.diff(tools, axis=0), axis=1).sum())
    seconds = 1.875 * max(along[-1] / JOINT_SPEED, length / TOOL_SPEED)
    n = max(CONTROL_FREQ // 2, int(np.ceil(seconds * CONTROL_FREQ)))
    s = np.linspace(0.0, 1.0, n + 1)[1:]
    u = s ** 3 * (10 - 15 * s + 6 * s ** 2)  # minimum jerk
    at = u * along[-1]
    Qs = np.column_stack([np.interp(at, along, fine[:, j]) for j in range(fine.shape[1])])
    poses = [scene.tool(q) for q in Qs]
    return np.array([p for p, _ in poses]), np.array([q for _, q in poses])


def _int_seed(random_state):
    """An integer seed for OMPL from an episode's ``random_state`` (None: 0, the same plan every time)."""
    if random_state is None:
        return 0
    if isinstance(random_state, (int, np.integer)) and not isinstance(random_state, bool):
        return int(random_state)
    if hasattr(random_state, "integers"):
        return int(random_state.integers(2 ** 31 - 1))
    if hasattr(random_state, "randint"):
        return int(random_state.randint(2 ** 31 - 1))
    raise ValueError(f"random_state: expected an integer seed, a numpy generator or None, got "
                     f"{random_state!r}")


def free_span(n, grip, *, let_go=False, leave=0.25, close_in=0.5):
    """The samples ``(start, stop)`` of an adapted path of ``n`` samples that are free space, or None.

    The first ``leave`` of a segment leaves as its demonstration did (a lift off the table); from
    ``close_in`` on the demonstration's own close-in is pinned. Between them the path relates to no
    object and is free. A segment that keeps the gripper open right after one that let go (``let_go``)
    only leaves: free to its end.

    Examples
    --------
    >>> free_span(41, [-1] * 41), free_span(41, [-1] * 41, let_go=True), free_span(3, [-1] * 3)
    ((10, 20), (10, 40), None)
    """
    grip = np.asarray(grip, float)
    start = int(np.ceil(leave * (n - 1)))
    stop = n - 1 if let_go and (grip <= 0).all() else int(np.floor(close_in * (n - 1)))
    return (start, stop) if stop - start >= 2 else None


def free_move(env, obs, P, Q, G, span, *, held=None, random_state=None, margin=MARGIN):
    """The tool path ``P (n, 3)``, ``Q (n, 4)`` (gripper commands ``G (n,)``) with its free ``span``
    planned for the whole arm where the path as it is would bring a body within ``margin`` of the scene.

    The arm's joints are followed along the path from where they are now (inverse kinematics, each pose
    from the last, as far as the arm reaches). The span is narrowed to its first and last clear followed
    states (a path that starts or ends at the scene is the skill's own there; one that leaves the arm's
    reach is driven as adapted beyond it); if every state between them, densified, is clear, the path
    is returned as it is. Otherwise the narrowed span is replaced by a joint path from
    :func:`plan_transit` between the followed joints at its ends, driven as tool poses, and the path
    goes on from there as before.

    Returns
    -------
    P, Q, G : ndarray
        The path (``n`` changes when the span is replaced: the planned move keeps the span's first
        gripper command); the samples before the span are unchanged.
    report : dict
        ``{"planned": bool, "seconds": float, "span": (start, stop), "samples": int, "why": str}``
        (``samples``: the planned move's samples that replace the span's; ``why``: ``"blocked"`` (planned),
        or why not: ``"short"``, ``"clear"``, ``"no clear state"``, ``"out of reach at sample K"``).

    Raises
    ------
    MotionPlanningError
        The span is blocked and no planned path is found (one line, :func:`plan_transit`).

    Examples
    --------
    >>> P2, Q2, G2, report = free_move(env, obs, P, Q, G, (10, 20))  # doctest: +SKIP
    >>> report["planned"] in (True, False)  # doctest: +SKIP
    True
    """
    tic = _time.perf_counter()
    random_state = _int_seed(random_state)
    a, b = span
    report = {"planned": False, "seconds": 0.0, "span": (int(a), int(b)), "samples": 0, "why": "short"}
    if np.linalg.norm(np.diff(P[a:b + 1], axis=0), axis=1).sum() < SHORTEST:
        return P, Q, G, report
    scene = ArmScene(env, held=held, margin=margin)
    q = np.asarray(obs["robot0_joint_pos"], float)
    scene.allow(q)  # what the hand stands at now (what it just let go of) is not what a transit avoids
    followed = []
    for k in range(b + 1):
        nxt = scene.ik(P[k], Q[k], q)
        if nxt is None:
            break  # unreachable on this branch: the planner's goal is looked for below
        q = nxt
        followed.append(q)
    if len(followed) <= a:
        # the path leaves the arm's reach before the span starts: no joints to plan from; it is driven as
        # adapted, and where the tool stops short is the episode's to judge
        report.update(seconds=_time.perf_counter() - tic, why=f"out of reach at sample {len(followed)}")
        return P, Q, G, report
    # the span runs between clear states: where the path as adapted starts or ends at the scene (a lift
    # still beside what it left, a demonstration's close-in that begins at a bin's wall) it is the
    # skill's own, not free space, and is driven as it is
    clear = [k for k in range(a, len(followed)) if scene.blocking(followed[k]) is None]
    if not clear:
        report.update(seconds=_time.perf_counter() - tic, why="no clear state")
        return P, Q, G, report
    # a path that leaves the arm's reach inside the span (an adaptation that runs beyond it) is planned up
    # to where the arm still follows it, and driven as adapted from there
    a, b = clear[0], clear[-1]
    report["span"] = (int(a), int(b))
    if b - a < 2 or all(scene.motion_clear(followed[k], followed[k + 1]) for k in range(a, b)):
        report.update(seconds=_time.perf_counter() - tic,
                      why="clear" if len(followed) == span[1] + 1 else f"clear to sample {len(followed)}")
        return P, Q, G, report
    start, goal = followed[a], followed[b]
    joints, _ = plan_transit(scene, start, goal, random_state=random_state)
    Pm, Qm = _timed(scene, joints)
    report.update(planned=True, seconds=_time.perf_counter() - tic, samples=len(Pm), why="blocked")
    G = np.asarray(G)
    return (np.vstack([P[:a + 1], Pm, P[b + 1:]]), np.vstack([Q[:a + 1], Qm, Q[b + 1:]]),
            np.concatenate([G[:a + 1], np.full(len(Pm), G[a]), G[b + 1:]]), report)
