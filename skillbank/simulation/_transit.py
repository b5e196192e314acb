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
  shortened by OMPL's simplifier (every pass, never cut by a clock: the same seed, the same path on any
  machine); the search has a time bound, and a failure is one line naming the start, the goal and the
  geom that blocks.
- :func:`free_move` takes a tool path and the span of it that is free space, follows it with inverse
  kinematics from the arm's joints and, only where that would bring a body within the margin, replaces
  the span by the planned path's tool poses (forward kinematics at the control rate, timed by the time
  law, no joint faster than :data:`JOINT_SPEED`): what follows the span is driven as before, from where
  the planned move ends.
- :func:`free_span` says which part of an adapted segment is free space, from the data alone: up to
  where the demonstration's own close-in is pinned (``CLOSE_IN``), or to the end for a segment that only
  leaves what the last one let go of; :func:`free_move` starts it where the path, followed from the
  arm's joints, first leaves everything within the margin (a lift off the table, a hand leaving what it
  let go of, leaves as the demonstration did).
"""

from __future__ import annotations

import time as _time

import numpy as np

from ..robots._motion import MotionPlanningError, _ompl, _ompl_path
from ..robots._time_law import time_law
from ._arm_scene import JOINT_STEP, MARGIN, ArmScene, _where
from ._robosuite import CONTROL_FREQ

__all__ = ["ArmScene", "plan_transit", "free_move", "free_span", "move_to", "reachable", "check_planner",
           "transit_timing", "PLANNER_CHOICES", "MARGIN"]

#: ``planner`` values: OMPL in the scene's MuJoCo geometry, or the tool paths as adapted.
PLANNER_CHOICES = ("ompl", "none")
#: Seconds a search may take.
TIME_LIMIT = 3.0
#: rad/s: the fastest any joint turns in a driven planned move.
JOINT_SPEED = 0.8
#: rad/s^2: the fastest any joint speeds up or slows down in it (the peak of the minimum-jerk law it
#: replaced, over a radian at 0.8 rad/s).
JOINT_ACCELERATION = 1.0
#: m/s: the fastest the tool moves in it.
TOOL_SPEED = 0.25
#: Free spans shorter than this (m, tool) are driven as they are.
SHORTEST = 0.05
#: Poses of the close-in tried, evenly along it, for a planned move's end when the free span's end is
#: out of the arm's reach (each an inverse kinematics).
FORWARD = 10


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


def plan_transit(scene, q_start, q_goal, *, time_limit=TIME_LIMIT, simplify=True,
                 random_state=None):
    """A joint path from ``q_start`` to ``q_goal`` on which the arm, gripper and held object stay clear.

    Parameters
    ----------
    scene : ArmScene
    q_start, q_goal : array of shape (n_joints,)
    time_limit : float
        Seconds the search may take.
    simplify : bool
        Shorten the path with OMPL's simplifier (every pass: the same seed, the same path on any
        machine, however busy).
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
                         step=0.5, time_limit=time_limit, simplify=simplify,
                         random_state=random_state)
    for a, b in zip(Q[:-1], Q[1:], strict=True):  # never a silent success
        hit = scene.motion_blocking(a, b)
        if hit is not None:
            raise MotionPlanningError(
                f"transit planning: the path OMPL found from {_where(q0)} to {_where(q1)} is not clear: "
                f"{scene.describe(hit)}")
    return Q, _time.perf_counter() - tic


def _timed(scene, Q):
    """The tool poses (positions, quaternions) along joint waypoints ``Q`` at the control rate: the path,
    densified, timed by TOPP-RA from rest to rest (:func:`skillbank.robots.time_law`, the law ``plan``
    and ``library reuse`` use) at most :data:`JOINT_SPEED` and :data:`JOINT_ACCELERATION` per joint,
    stretched where the tool would pass :data:`TOOL_SPEED`; and the joints at each (the posture the
    controller keeps the arm's redundancy at while it drives the poses, :meth:`_Driver.posture`)."""
    fine = [Q[0]]
    for a, b in zip(Q[:-1], Q[1:], strict=True):
        k = int(np.ceil(np.abs(b - a).max() / (JOINT_STEP / 2)))
        fine.extend(a + s * (b - a) for s in np.linspace(0.0, 1.0, k + 1)[1:])  # k = 0: a repeated waypoint
    fine = np.array(fine)
    if len(fine) < 2:
        fine = np.vstack([fine, fine])
        times = np.array([0.0, 1.0 / CONTROL_FREQ])
    else:
        times = time_law(fine, velocity=JOINT_SPEED, acceleration=JOINT_ACCELERATION)
    tools = np.array([scene.tool(q)[0] for q in fine])
    steps = np.linalg.norm(np.diff(tools, axis=0), axis=1)
    fastest = float((steps / np.maximum(np.diff(times), 1e-12)).max())
    times = times * max(1.0, fastest / TOOL_SPEED)
    n = max(CONTROL_FREQ // 2, int(np.ceil(times[-1] * CONTROL_FREQ)))
    at = np.linspace(0.0, times[-1], n + 1)[1:]
    Qs = np.column_stack([np.interp(at, times, fine[:, j]) for j in range(fine.shape[1])])
    poses = [scene.tool(q) for q in Qs]
    return np.array([p for p, _ in poses]), np.array([q for _, q in poses]), Qs


def move_to(env, obs, position, quat, *, held=None, random_state=None, margin=MARGIN):
    """The tool poses of a whole-arm move, planned in joint space, from where the arm is to ``position``,
    ``quat`` (x, y, z, w): what a composed task's transit between two skills drives.

    The goal's joints are those inverse kinematics reaches following the straight tool line there from the
    arm's joints (the branch the arm is on; directly from its joints where the line leaves its reach);
    :func:`plan_transit` joins them, every link, the gripper and ``held`` kept ``margin`` clear of the
    scene (what the hand stands at now, what it has just let go of, excepted), and :func:`_timed` gives the
    tool poses at the control rate.

    Returns
    -------
    P : ndarray of shape (n, 3)
    Q : ndarray of shape (n, 4)
    seconds : float
        The goal's inverse kinematics, the search's and the simplification's time.
    J : ndarray of shape (n, dof)
        The planned joints at each pose: an arm with joints to spare (the Panda's seven) is kept at them
        while its tool is driven along the poses (:meth:`~skillbank.simulation._robosuite._Driver.posture`).

    Raises
    ------
    MotionPlanningError
        One line: the goal out of the arm's reach, or :func:`plan_transit`'s.

    Examples
    --------
    >>> P, Q, seconds, J = move_to(env, obs, [0.1, 0.0, 1.0], [1, 0, 0, 0])  # doctest: +SKIP
    >>> bool(np.linalg.norm(P[-1] - [0.1, 0.0, 1.0]) < 1e-3)  # doctest: +SKIP
    True
    """
    tic = _time.perf_counter()
    scene = ArmScene(env, held=held, margin=margin)
    q0 = np.asarray(obs["robot0_joint_pos"], float)
    scene.allow(q0)
    there = np.asarray(position, float)
    q = _reached(scene, obs["robot0_eef_pos"], there, quat, q0)
    if q is None:
        raise MotionPlanningError(f"transit planning: the tool pose {np.round(there, 3).tolist()} m is out "
                                  f"of the arm's reach from {_where(q0)}")
    joints, _ = plan_transit(scene, q0, q, random_state=_int_seed(random_state))
    P, Q, J = _timed(scene, joints)
    return P, Q, _time.perf_counter() - tic, J


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


def free_span(n, grip, *, let_go=False, close_in=0.5):
    """The samples ``(start, stop)`` of an adapted path of ``n`` samples that may be free space, or None.

    From ``close_in`` on, the demonstration's own close-in is pinned; before it the path relates to no
    object, once it has left what it starts at (:func:`free_move` moves the span's start on to where the
    path, followed from the arm's joints, is first clear: a lift off the table leaves as its
    demonstration did). A segment that keeps the gripper open right after one that let go (``let_go``)
    only leaves: free to its end.

    Examples
    --------
    >>> free_span(41, [-1] * 41), free_span(41, [-1] * 41, let_go=True), free_span(3, [-1] * 3)
    ((0, 20), (0, 40), None)
    """
    grip = np.asarray(grip, float)
    stop = n - 1 if let_go and (grip <= 0).all() else int(np.floor(close_in * (n - 1)))
    return (0, stop) if stop >= 2 else None


def free_move(env, obs, P, Q, G, span, *, held=None, random_state=None, margin=MARGIN, slack=0.0,
              recorded=None):
    """The tool path ``P (n, 3)``, ``Q (n, 4)`` (gripper commands ``G (n,)``) with its free ``span``
    replaced by a move planned for the whole arm.

    The free span is where the demonstration's motion relates to no object (:func:`free_span`): what
    the adapted path does there is the demonstration's way of getting across, not the skill, and a
    person's halting, wandering way across, moved onto a new scene, may leave the arm's reach or sweep a
    link through a bin's wall. The span's start is where the arm is after the part before it (inverse
    kinematics followed along the path from the arm's joints; where that part leaves the arm's reach,
    the last pose it takes), moved on along the path to its first clear state; its end is the first pose
    of the skill's own part after it (inverse kinematics along a straight line from the start; out of
    reach, the first of :data:`FORWARD` poses along the close-in the arm takes), moved back along the
    path to its last clear state (a close-in that begins at a bin's wall is the skill's own).
    :func:`plan_transit` joins the two and the planned joint path is driven as tool poses
    (:func:`_timed`); the path goes on from its end as adapted. A ``held`` object keeps ``margin`` and
    ``slack`` more (:class:`ArmScene`): what it may move in the hand on the way. ``recorded`` (one row of
    joints per sample of ``P``: the source's, where it was recorded on this arm): on an arm with a joint
    to spare, the span's end takes the joints nearest those the demonstrator's arm had there when they
    are clear, as a start pose does (issue 43, item 3): inverse kinematics along a straight line from
    the start, with the orientation of the end held all the way, leaves a Panda's elbow wherever its
    spare joint drifts, and folded it the other way round (a wrist that turns a quarter turn to face a
    door: the elbow on the door's frame). An arm of six joints keeps the branch it is on (the UR5e's
    recorded branch at one span's end put its upper arm into a bin at a later move: tuning seed 2304).

    Returns
    -------
    P, Q, G : ndarray
        The path (``n`` changes: the planned move keeps the span's first gripper command); the samples
        before the span are unchanged.
    report : dict
        ``{"planned": bool, "seconds": float, "span": (start, stop), "samples": int, "why": str}``
        (``samples``: the planned move's samples that replace the span's; ``why``: ``"planned"``, or why
        the span is driven as adapted: ``"short"``, ``"out of reach at sample K"``, ``"no clear state:
        ..."`` naming what is within the margin at the span's start or end); a planned move adds
        ``"joints"``: its joints at each of its samples, which follow sample ``start`` of the path
        returned (the posture :func:`move_to`'s ``J`` is).

    Raises
    ------
    MotionPlanningError
        No planned path is found (one line, :func:`plan_transit`).

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
    if np.linalg.norm(P[b] - P[a]) < SHORTEST:
        return P, Q, G, report
    scene = ArmScene(env, held=held, margin=margin, slack=slack)
    q = np.asarray(obs["robot0_joint_pos"], float)
    for k in range(a + 1):
        nxt = scene.ik(P[k], Q[k], q)
        if nxt is None:
            # the part before the span leaves the arm's reach (a lift from a far place, moved onto this
            # scene): the planned move takes over from the last pose the arm takes (from where it
            # stands, at the first sample)
            a = max(k - 1, 0)
            break
        q = nxt
    # from the first clear state along the path: a hand at what it has just let go of, or a lift still
    # beside what it left, leaves as the skill's own path does, until nothing is within the margin
    while scene.blocking(q) is not None and a < b - 2:
        nxt = scene.ik(P[a + 1], Q[a + 1], q)
        if nxt is None:
            break
        a, q = a + 1, nxt
    start = q
    goal = None
    if recorded is not None and np.shape(recorded)[1:] == np.shape(start) and len(start) > 6:
        goal = scene.ik(P[b], Q[b], np.asarray(recorded[b], float))
        if goal is not None and scene.blocking(goal) is not None:
            goal = None
    if goal is None:
        goal = _reached(scene, P[a], P[b], Q[b], start)
    if goal is None:
        # the demonstration's way across, moved onto this scene, leaves the arm's reach there (a
        # person's reach swings wide): it is free space, so the planned move goes on to the first pose
        # of the close-in the arm takes
        for k in np.unique(np.linspace(b + 1, len(P) - 1, min(FORWARD, len(P) - 1 - b)).astype(int)):
            goal = _reached(scene, P[a], P[k], Q[k], start)
            if goal is not None:
                b = int(k)
                break
    while goal is not None and scene.blocking(goal) is not None and b > a + 2:
        back = scene.ik(P[b - 1], Q[b - 1], goal)
        if back is None:
            break  # the state before it is out of reach: no clear one on this side
        b, goal = b - 1, back  # to the last clear state before the skill's own part (a close-in at a wall)
    report["span"] = (int(a), int(b))
    if goal is None:
        report.update(seconds=_time.perf_counter() - tic, why=f"out of reach at sample {b}")
        return P, Q, G, report
    for end, q_end in (("start", start), ("end", goal)):
        hit = scene.blocking(q_end)
        if hit is not None:
            report.update(seconds=_time.perf_counter() - tic,
                          why=f"no clear state: at its {end} {scene.describe(hit)}")
            return P, Q, G, report
    joints, _ = plan_transit(scene, start, goal, random_state=random_state)
    Pm, Qm, Jm = _timed(scene, joints)
    report.update(planned=True, seconds=_time.perf_counter() - tic, samples=len(Pm), why="planned", joints=Jm)
    G = np.asarray(G)
    return (np.vstack([P[:a + 1], Pm, P[b + 1:]]), np.vstack([Q[:a + 1], Qm, Q[b + 1:]]),
            np.concatenate([G[:a + 1], np.full(len(Pm), G[a]), G[b + 1:]]), report)


def reachable(env, obs):
    """``reachable(p, q)``: whether the arm, from its joints now, can put the tool at position ``p``,
    orientation ``q`` (x, y, z, w), within its joint limits (:func:`_reached` on the scene's own model; a
    wrist turned past the last joint's limit cannot). The model is copied at the first call.

    Examples
    --------
    >>> can = reachable(env, obs)  # doctest: +SKIP
    >>> can(obs["robot0_eef_pos"], obs["robot0_eef_quat"])  # doctest: +SKIP
    True
    """
    scene = []
    q0 = np.asarray(obs["robot0_joint_pos"], float)
    here = np.asarray(obs["robot0_eef_pos"], float)

    def can(p, q) -> bool:
        if not scene:
            scene.append(ArmScene(env))
        return _reached(scene[0], here, p, q, q0) is not None

    return can


def _reached(scene, here, there, quat, q):
    """Joints that put the tool at ``there``, ``quat`` on the arm's branch at ``q`` (the tool at ``here``):
    inverse kinematics a centimetre at a time along the straight line (damped least squares from a pose
    it is near stays on the branch), else directly from ``q``; None out of reach."""
    here, there = np.asarray(here, float), np.asarray(there, float)
    q0 = q
    for s in np.linspace(0.0, 1.0, max(2, int(np.ceil(np.linalg.norm(there - here) / 0.01)) + 1))[1:]:
        q = scene.ik(here + s * (there - here), quat, q)
        if q is None:
            return scene.ik(there, quat, q0, iters=1000)
    return q
