"""Reuse of stored primitives for a new task: select, adapt, rank, then learn and reproduce."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core import Demonstration
from ..core._validation import check_array, check_positive, check_time, numerical_errors, summarise
from ..representations import REPRESENTATIONS, fit_reproduce, representation
from ..robots import CLEARANCE, KinematicsError, RobotModel, robot_model, to_tool
from ._candidates import SHORTLIST, Selection, select_candidates
from ._clear import keep_clear
from ._execution import check_duration, check_limits, executable_dict, make_executable, retime

__all__ = ["ReuseResult", "reuse", "reproduce_selection", "METHODS"]

#: The method names, in the registry's order (``skillbank.representations.REPRESENTATIONS``).
METHODS = tuple(REPRESENTATIONS)
_WORDS = {"via": "via-points", "start_velocity": "start velocity", "end_velocity": "end velocity"}


@dataclass
class ReuseResult:
    """A reproduction built from stored primitives.

    Attributes
    ----------
    trajectory : Demonstration
        Time from 0. Stream ``"position"``; where the candidates recorded them
        ``"orientation"`` (adapted to the orientation constraints),
        ``"gripper"`` and other streams (time-warped from the best
        candidate); ``"joints"`` with a robot. Metadata holds ``method``,
        ``used``, ``k``, ``time_scale`` and, with joints, ``joint_names``.
    used : list
        Ids of the candidates the representation learned from, best first.
    rejected : dict
        Id -> reason for every candidate that was dropped.
    constraint_error : float
        Largest distance of a constrained sample of ``trajectory`` to its target.
    collision : bool
        True when a sample of ``trajectory``, or a segment between two, is inside an obstacle.
    ranking : list of (id, float)
        Every usable candidate with its adapted curve length, in rank order.
    method : str
    k : int
        Number of candidates used.
    velocity_error : float
        Largest boundary-velocity error (0.0 without velocity constraints).
    candidates : list of Demonstration
        The adapted candidates that were used, best first.
    message : str
        What happened, in words.
    orientation_error : float
        Largest angle (radians) between a constrained orientation and its target (0.0 without).
    peaks : dict
        Peak velocity and acceleration of ``position``, ``orientation`` and
        ``joints`` after time scaling (see :func:`peak_rates`).
    time_scale : float
        Duration after timing over duration before (1.0: the time base met the
        limits; with the uniform law, the factor every time was stretched by).
    notes : list of str
        Streams carried or dropped, time scaling, the representation's warnings, repairs.
    clearance : Clearance or None
        With a robot and obstacles: every moving body's clearance along ``trajectory``'s joints
        (:func:`skillbank.robots.clearance`), after any repair.
    """

    trajectory: Demonstration
    used: list
    rejected: dict
    constraint_error: float
    collision: bool
    ranking: list
    method: str
    k: int
    velocity_error: float = 0.0
    candidates: list = field(default_factory=list)
    message: str = ""
    orientation_error: float = 0.0
    peaks: dict = field(default_factory=dict)
    time_scale: float = 1.0
    notes: list = field(default_factory=list)
    clearance: object = None

    def to_dict(self) -> dict:
        """JSON-able summary: time, every stream as nested lists, ids as int or str.

        ``trajectory`` is the position path (as before streams were added);
        ``joint_names`` and ``peak_joint_velocity`` are there with a
        ``joints`` stream only.

        Examples
        --------
        >>> import numpy as np
        >>> from skillbank import Constraints
        >>> s = np.linspace(0, 1, 20)
        >>> res = reuse([np.c_[s, s]], Constraints(goal=[1.0, 2.0]), method="lte")
        >>> sorted(res.to_dict())  # doctest: +NORMALIZE_WHITESPACE
        ['collision', 'constraint_error', 'notes', 'orientation_error', 'peaks', 'rejected', 'streams', 't',
         'trajectory', 'used']
        """
        doc = executable_dict(self.trajectory, orientation_error=self.orientation_error, peaks=self.peaks,
                              notes=self.notes)
        doc.update({"used": [_json_id(i) for i in self.used],
                    "rejected": {str(i): str(r) for i, r in self.rejected.items()},
                    "constraint_error": float(self.constraint_error), "collision": bool(self.collision)})
        return doc


def _json_id(i):
    if isinstance(i, (bool, np.bool_)):
        return str(i)
    if isinstance(i, (int, np.integer)):
        return int(i)
    return i if isinstance(i, str) else str(i)


def _check_k(k, method: str, n_usable: int) -> int:
    cls = representation(method)
    if k is None:
        return min(cls.default_k, n_usable)
    k = check_positive(k, name="k", integer=True)
    if cls.single_demo and k != 1:
        raise ValueError(f"k: method {method!r} uses exactly one candidate, got k={k}")
    return min(k, n_usable)


def reproduce_selection(selection: Selection, constraints, *, method: str = "promp", k=None,
                        random_state=None, t=None, duration=None, robot=None, limits=None,
                        branch=None, time_law: str = "toppra", clearance_margin=None) -> ReuseResult:
    """Learn ``method`` from the ``k`` best candidates of a selection and reproduce the task.

    The second half of :func:`reuse`; call it directly to try several
    methods on one selection without adapting the candidates again.

    Parameters
    ----------
    selection : Selection
        From :func:`select_candidates` with the same ``constraints``.
    constraints : Constraints
    method, k, random_state, t, duration, robot, limits, branch, time_law, clearance_margin
        As in :func:`reuse`. ``duration`` stretches the reproduction's time
        base uniformly here; :func:`reuse` stretches the candidates first,
        so that velocity constraints mean the same in the result.

    Returns
    -------
    ReuseResult

    Examples
    --------
    >>> import numpy as np
    >>> from skillbank import Constraints
    >>> from skillbank.selection import select_candidates
    >>> s = np.linspace(0, 1, 30)
    >>> c = Constraints(goal=[1.0, 0.5])
    >>> sel = select_candidates([np.c_[s, s * a] for a in (0.0, 1.0, 2.0)], c)
    >>> [reproduce_selection(sel, c, method=m).k for m in ("ja", "promp")]
    [1, 3]
    """
    cls = representation(method)
    if not isinstance(selection, Selection):
        raise ValueError(f"selection: expected a Selection, got {type(selection).__name__}")
    if t is not None:
        t = check_time(t, name="t", min_samples=cls.min_samples)
    duration = _check_duration(duration, t)
    limits = check_limits(limits)
    if not selection.candidates:
        # The first few reasons and a count: one line even for a skill of thousands of primitives
        # (every reason is in Selection.rejected and in ReuseResult.rejected of a successful reuse).
        reasons = summarise((f"{i}: {r}" for i, r in selection.rejected.items()), sep="; ")
        raise ValueError(f"no usable candidate: {reasons}")
    k = _check_k(k, method, len(selection.candidates))
    chosen = selection.candidates[:k]
    notes = []
    task = constraints
    missing = cls.unsupported(constraints)
    if missing:
        # The candidates were edited through these already; the method follows them from there.
        task = constraints.replace(**{name: () if name == "via" else None for name in missing})
        what = " and ".join(_WORDS[name] for name in missing)
        notes.append(f"{method}: {what} followed only through the adapted demonstration")
    # task keeps every obstacle of constraints, so its collision verdict is the task's
    out, collision, more = fit_reproduce(method, [c.demo() for c in chosen], task, random_state=random_state,
                                         n_steps=None if t is None else len(t))
    notes += more
    if t is None:
        time = out.t - out.t[0]
        if duration is not None:
            time = time * (duration / time[-1])
            time[-1] = duration
    else:
        time = t
    used = [c.id for c in chosen]
    metadata = {"method": method, "used": used, "k": k, "rank": selection.rank}
    done = make_executable(Demonstration(time, {"position": out["position"]}, metadata),
                           [c.recorded() for c in chosen], constraints, ids=used, robot=robot, limits=limits,
                           fixed_time=t is not None, by_index=t is not None, branch=branch,
                           time_law=time_law, clearance_margin=clearance_margin)
    traj = done.trajectory
    Y = traj["position"]
    with numerical_errors(f"reuse ({method} result check)"):
        error = constraints.position_error(Y)
        vel_error = constraints.velocity_error(Y, traj.t)
    message = (f"{method} from {k} of {len(selection.candidates)} usable candidate(s) "
               f"({len(selection.rejected)} rejected, ranked by {selection.rank}); constraint error "
               f"{error:.3g}; {'collides' if collision else 'collision-free'}")
    if constraints.has_orientation:
        message += f"; orientation error {done.orientation_error:.3g} rad"
    if notes:
        message += "; " + "; ".join(notes)
    return ReuseResult(
        trajectory=traj, used=used, rejected=dict(selection.rejected), constraint_error=error,
        collision=collision, ranking=selection.ranking, method=method, k=k, velocity_error=vel_error,
        candidates=[c.demo() for c in chosen], message=message, orientation_error=done.orientation_error,
        peaks=done.peaks, time_scale=done.time_scale, notes=notes + done.notes,
    )


def _check_duration(duration, t):
    if duration is None:
        return None
    if t is not None:
        raise ValueError("duration: give a duration or a time base t, not both")
    return check_duration(duration)


def _retimed(primitives, duration):
    """Each primitive's time shifted to 0 and stretched to ``duration`` (arrays get ``linspace``)."""
    if not isinstance(primitives, (list, tuple)):
        return primitives  # select_candidates names the problem
    out = []
    for k, prim in enumerate(primitives):
        if isinstance(prim, Demonstration):
            out.append(retime(prim, duration) if prim.n_steps >= 2 else prim)
        else:
            Y = check_array(prim, name=f"primitives[{k}]", ndim=2)
            out.append(Demonstration(np.linspace(0.0, duration, Y.shape[0]), {"position": Y})
                       if Y.shape[0] >= 2 else Y)
    return out


def _at_tool(primitives, model, ids) -> tuple[list, list]:
    """The primitives' poses converted to ``model``'s tool (:func:`skillbank.robots.to_tool`), with notes.

    Arrays carry no point and no orientation: inverse kinematics names what they lack.
    """
    if not isinstance(primitives, (list, tuple)):
        return primitives, []  # select_candidates names the problem
    out, notes = [], []
    for k, prim in enumerate(primitives):
        if isinstance(prim, Demonstration):
            name = ids[k] if ids is not None and k < len(ids) else k
            prim, more = to_tool(prim, model, what=f"primitive {name}")
            notes += [n for n in more if n not in notes]
        out.append(prim)
    return out, notes


def reuse(primitives, constraints, *, method: str = "promp", k=None, ids=None, random_state=None, t=None,
          rank: str = "shortlist", shortlist: int = SHORTLIST, progress=None, duration=None, robot=None,
          limits=None, branch=None, clearance_margin=None, time_law: str = "toppra") -> ReuseResult:
    """Reproduce a skill under new constraints from stored primitives (the paper's selection).

    1. Adapt every candidate with Laplacian trajectory editing to the constraints.
    2. Drop those that still collide or miss a constraint (``rejected`` says why).
    3. Rank the rest: by default the ``shortlist`` candidates the edit deformed
       least, shortest adapted curve first (the paper's curve-length
       criterion, among the candidates that fit the task), then the others.
    4. Fit the representation on the ``k`` best adapted candidates and reproduce the constraints.
    5. Complete the pose and the other streams (:func:`make_executable`):
       orientation from the candidates, turned to the orientation constraints
       keeping the rotation profile; gripper and other recorded streams of
       the best candidate, time-warped; joints by inverse kinematics with a
       ``robot``; time from 0, re-timed to meet ``limits`` (``time_law``).

    Parameters
    ----------
    primitives : list of Demonstration or array of shape (n_steps, n_dims)
        The candidates (stream ``"position"``); arrays get the time base ``0, 1, 2, ...``.
    constraints : Constraints
        Start, goal, via-points, boundary velocities and obstacles of the new task.
    method : {"lte", "ja", "promp", "elmap", "dmp"}, default="promp"
        Names of :data:`~skillbank.representations.REPRESENTATIONS`. ``"lte"``
        (:class:`~skillbank.representations.LaplacianEditor`) returns the best
        adapted candidate as it is; the others learn
        :class:`~skillbank.representations.JerkAccuracy`,
        :class:`~skillbank.representations.ProMP`,
        :class:`~skillbank.representations.ElasticMap` or
        :class:`~skillbank.representations.DMP`. A DMP cannot take via-points:
        it is reproduced with start, goal and obstacles only, and follows
        via-points through its adapted demonstration (``constraint_error``
        says how closely); it meets a start and goal to about 1e-3 of their
        change from the demonstration's, here usually ~0 since the
        demonstrations were edited to them.
    k : int, optional
        Candidates to learn from; default 1 for lte, ja and dmp, 3 for promp
        and elmap, or fewer when fewer are usable. lte and ja take exactly 1.
    ids : list, optional
        One id per primitive, carried into ``used``, ``rejected`` and
        ``ranking``; default ``0 .. n-1``.
    random_state : int, RandomState or None, default=None
        Seeds the representation where it samples (ProMP).
    t : array-like of shape (n_steps,), optional
        Time base of the reproduction; candidates are resampled to its length
        first. Default: each candidate keeps its own, the reproduction has the
        representation's default length.
    rank : {"shortlist", "length", "endpoints", "deformation"}, default="shortlist"
        Ranking criterion, see :func:`select_candidates`; ``"length"`` applies
        the paper's curve length to every candidate.
    shortlist : int, default=3
        Size of the shortlist for ``rank="shortlist"``.
    progress : callable, optional
        Called as ``progress(done, total)`` while the candidates are adapted
        (see :func:`select_candidates`).
    duration : float, optional
        Seconds of the reproduction (every candidate is stretched to it
        first); default the candidates' mean duration. Not with ``t``.
    robot : str or RobotModel, optional
        ``"ur5e"`` (a name of :data:`skillbank.robots.ROBOTS`) adds a
        ``joints`` stream by inverse kinematics of the pose path (positions
        in metres and orientations in the robot's base frame), on the branch
        of the best candidate's recorded joints when it has them. The robot's
        own joint velocity and acceleration limits always apply. Before
        anything is adapted, each primitive's poses are converted from the
        point they are of (``metadata["pose_of"]``: the flange, a gripper's
        TCP or grip site, an offset) to the robot's tool
        (:func:`skillbank.robots.to_tool`), so the constraints are the
        tool's; a primitive whose point is unknown is an error.
    branch : int or str, optional
        With ``robot``: the inverse-kinematics branch to follow (a name of the
        robot's ``branch_names``), instead of the recorded joints' branch.
    clearance_margin : float, optional
        With ``robot``: metres every moving body of the robot (links and gripper) keeps from every
        obstacle (default :data:`skillbank.robots.CLEARANCE`, 5 mm). A reproduction that comes closer
        is repaired with via points that move that body away (:func:`keep_clear`), up to
        ``MAX_REPAIRS`` of them; if it still does, its candidates are rejected with a reason naming
        the body, the obstacle and the time, and the next ones are tried. The start, which no repair
        moves, is the recorded joints' branch when that keeps the margin, else the configuration at
        the start pose clear of the obstacles and of the robot itself nearest it (as a plan's start:
        ``robots._start.clear_configurations``), with a note; without a branch given.
    limits : dict, optional
        Velocity and acceleration limits (keys ``velocity``,
        ``acceleration``, ``angular_velocity``, ``angular_acceleration``,
        ``joint_velocity``, ``joint_acceleration``). A time base that breaks
        one is re-timed by ``time_law`` (a note says how and to what); with
        ``t`` a limit that needs more time is an error.
    time_law : {"toppra", "uniform"}, default="toppra"
        With ``robot``: the joint path's fastest timing under the joint limits
        (:func:`skillbank.robots.time_law`, never faster than the time base
        asked for), the task-space limits then met by a uniform stretch; or the
        whole time base stretched uniformly (``"uniform"``, the only law
        without a robot). See :func:`make_executable`.

    Returns
    -------
    ReuseResult

    Raises
    ------
    ValueError
        ``"no usable candidate: <id>: <reason>; ..."`` when every candidate is
        rejected (the first three reasons, then ``"and <n> more"``), or on
        malformed input (naming the argument), or, naming the step, when a
        computation overflows.

    Examples
    --------
    >>> import numpy as np
    >>> from skillbank import Constraints, Sphere
    >>> s = np.linspace(0.0, 1.0, 100)
    >>> prims = [np.column_stack([s, a * np.sin(np.pi * s)]) for a in (0.2, 0.3, 0.4)]
    >>> c = Constraints(start=[0.0, 0.0], goal=[1.0, 0.2], obstacles=[Sphere([0.5, 0.3], 0.05)])
    >>> res = reuse(prims, c, method="promp")
    >>> res.used, res.collision, res.constraint_error < 1e-6
    ([0, 1, 2], False, True)
    """
    cls = representation(method)
    if k is not None and cls.single_demo:
        _check_k(k, method, 1)
    duration = _check_duration(duration, t)
    check_limits(limits)
    model = None if robot is None else robot if isinstance(robot, RobotModel) else robot_model(robot)
    if branch is not None and model is not None:
        model.branch_index(branch)  # an unknown branch fails before the candidates are adapted
    if duration is not None:
        primitives = _retimed(primitives, duration)
    converted = []
    if model is not None:
        # the constraints are the robot's tool's: the poses become its tool's before anything is adapted
        primitives, converted = _at_tool(primitives, model, ids)
    selection = select_candidates(primitives, constraints, ids=ids, t=t, rank=rank, shortlist=shortlist,
                                  min_samples=cls.min_samples, progress=progress)
    margin = CLEARANCE if clearance_margin is None else check_positive(
        clearance_margin, name="clearance_margin", allow_zero=True)
    retrying = False
    while True:
        def make(task, selection=selection):
            if task is not constraints:  # a repair's via points: the same candidates, edited to them too
                again = select_candidates(primitives, task, ids=ids, t=t, rank=rank, shortlist=shortlist,
                                          min_samples=cls.min_samples)
                keep = {c.id for c in selection.candidates}
                lost = {i: r for i, r in again.rejected.items() if i in keep}
                selection = Selection(candidates=[c for c in again.candidates if c.id in keep],
                                      rejected={**selection.rejected, **lost}, rank=again.rank)
            result = reproduce_selection(selection, task, method=method, k=k, random_state=random_state, t=t,
                                         duration=duration, robot=model if model is not None else robot,
                                         limits=limits, branch=branch, time_law=time_law,
                                         clearance_margin=margin)
            return result, result.trajectory

        if model is None:
            return make(constraints)[0]
        try:
            done = keep_clear(make, constraints, model, margin=margin)
        except KinematicsError as exc:
            if not retrying:
                raise  # the best candidates' own failure: the task's (a goal out of reach), said as it is
            # a candidate tried because better ones hit the robot: its failure rejects it, the next is tried
            n = _check_k(k, method, len(selection.candidates))
            more = {c.id: str(exc) for c in selection.candidates[:n]}
        else:
            result = done.result
            if done.reason is None:
                result.clearance = done.clearance
                result.notes = converted + result.notes + done.notes
                if done.via:
                    result.message += "; " + "; ".join(done.notes)
                return result
            # even repaired, the reproduction from these candidates takes a body of the robot into an
            # obstacle: reject them and learn from the next ones (each one's tool point was clear: they were
            # edited so)
            more = {i: done.reason for i in result.used}
        retrying = True
        left = [c for c in selection.candidates if c.id not in more]
        selection = Selection(candidates=left, rejected={**selection.rejected, **more}, rank=selection.rank)
        if not left:
            reasons = summarise((f"{i}: {r}" for i, r in selection.rejected.items()), sep="; ")
            raise ValueError(f"no usable candidate: {reasons}")
