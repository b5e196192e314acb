"""Skills of a library executed in robosuite scenes they were not shown: ``skillbank sim evaluate``.

For every episode the environment is reset from its own seed (robosuite's
sampler draws the object placement), the library's demonstration whose
objects started nearest the new placement is the source, and its primitives
are executed one after the other, in closed loop: each is adapted from where
the robot is now to a goal that the scene gives.

Where a primitive's goal stands comes from the data, not from the task's
name. :func:`~skillbank.selection.acted_on` tells what the primitive acts on
(the object it carries, the one it ends at, where it puts a carried one); the
*frame* its goal is kept in is then chosen among the candidates (the object
where it ends, the carried object where it was picked up, the carried object's
target, the world) as the one in which the primitive's skill (its cluster's
members acting on the same things) ends most consistently, the
task-parameterised view of a demonstration: a lift ends at a height above
where the cube was, a placement in a fixed bin at a place in the world, a
stacking on the other cube. The goal in the new scene is that frame's new pose
composed with the primitive's end pose in it.

Methods: the names of :data:`skillbank.selection.METHODS` adapt the
primitive (``lte``, the default, warps its shape to the new start and goal);
``rigid`` moves the recorded segment rigidly into the new frame
(``T_new · T_source⁻¹ · T_tool(t)``, after a short interpolation from the
current pose, as MimicGen's paper describes); ``replay`` replays the source's
actions open loop. Success is the environment's own ``_check_success()``,
checked every step (an episode ends when it holds); a failure names its
segment and reason (:data:`REASONS`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np

from ..core import (
    POSE_OF,
    Constraints,
    ViaPoint,
    exp_map,
    log_map,
    quaternion_angle,
    quaternion_to_matrix,
    slerp,
)
from ..core._rotations import quaternion_conjugate, quaternion_multiply
from ..core._validation import check_positive
from ..io import arm_of
from ..robots import MotionPlanningError
from ..segmentation import ArmSpan, arm_constraints, part_joints
from ..selection import METHODS, acted_on, object_streams, reuse
from ..store import open_store
from ._arms import check_pads, pose_points
from ._episodes import check_episode_cluster, fresh, run_episodes
from ._lockstep import ArmEnv, Lockstep, Stopped, arm_obs
from ._robosuite import (
    CONTROL_FREQ,
    _box,
    _Driver,
    _gripper,
    _min_jerk_at,
    _objects,
    _pads,
    _turn,
    _yaw,
    import_robosuite,
    recorded_robot,
    robosuite_robot,
    with_object_poses,
)
from ._support import articulated, fixtures, object_extents, object_symmetry, pad_half_width, support
from ._transit import check_planner, free_move, free_span, reachable, transit_timing

__all__ = ["evaluate", "REASONS", "BASELINES", "binomial_interval", "DRIVEN_ROBOT", "driven_robot"]

#: The arm ``sim evaluate`` and plans in robosuite scenes drive (robosuite's name), with its default gripper.
DRIVEN_ROBOT = "UR5e"

#: Why an episode failed, judged at the end of the segment that failed.
REASONS = {
    "missed grasp": "a segment that carries an object from a closed gripper ended without it: it never "
                    "left its place",
    "dropped": "a segment that carries an object lost it on the way",
    "collision": "an arm link (not the gripper) touched the table, a fixture or an object in or before the "
                 "segment that failed (a touch in an episode that succeeds is reported as arm_contact)",
    "unreachable": "the segment's goal could not be adapted to, or the tool ended more than 2 cm from it",
    "timeout": "the episode used up its horizon",
    "no transit": "with planner 'ompl': no collision-free joint path was found for a free-space move",
    "misplaced": "every segment did what it was for, yet the environment's check fails at the end",
}
#: Methods that do not adapt: the baselines.
BASELINES = ("rigid", "replay")
ARRIVED = 0.02  # m: farther than this from a segment's goal after settling is a failure to reach it
SETTLE = CONTROL_FREQ  # steps allowed, after a segment's path, to come within ARRIVE of its goal
ARRIVE = 0.002  # m: a segment's end is held until the tool is this near its goal (a nut on its peg: 2 mm)
RIGID_BLEND = 5  # steps of the rigid baseline's interpolation to the transformed segment (MimicGen: a few)
LEVER = 0.1  # m per radian: how far a turn of the wrist moves its fingertips (a gripper's length)
#: Phases of a segment pinned to its source's path moved onto the goal: the second half closes in as the
#: demonstration did (an approach from above stays one), the first is adapted from where the robot is.
CLOSE_IN = (0.5, 0.625, 0.75, 0.875)
LEAVE = (0.125, 0.25)  # and the first quarter leaves as the demonstration did
TURNS_WITH = 0.5  # a symmetric grasp's place stays when its ends agree twice as well as they are as turned
SYMMETRIES = (1, 2, 4)  # whole, half and quarter turns about the vertical: a goal's heading may repeat
NEIGHBOUR = 0.06  # m: a fingertip nearer another object's centre than this may touch it (a 4-10 cm object)
HELD = 0.01  # m: how far a held object may shift in the tool's frame and still be where the tool holds it
CARRIED = 0.02  # m: how much a carried object's distance to the tool may change before it is lost
OVER = 0.01  # m: how far above an object's top the fingertips pass while an approach travels


def binomial_interval(successes: int, n: int) -> tuple:
    """Wilson's 95 % interval of a success rate, ``(low, high)``.

    Examples
    --------
    >>> [round(v, 3) for v in binomial_interval(9, 10)]
    [0.596, 0.982]
    """
    if n <= 0:
        return (0.0, 1.0)
    from scipy.stats import binomtest  # core dependency; only when a rate is reported

    ci = binomtest(int(successes), int(n)).proportion_ci(method="wilson")
    return (float(ci.low), float(ci.high))


@dataclass
class _Segment:
    primitive: object  # store.Primitive
    relation: object  # Relation or None
    frame: tuple  # where the goal position is kept: ("world",) or (object, "start" | "end" | "target")
    turn: object = "held"  # where the goal orientation is kept: "held" (the tool's at the start) or a frame
    symmetry: int = 1  # quarter turns (4), half turns (2) or only whole turns (1) give the same goal
    #: whether a symmetric turn of the goal orientation turns the tool's place on the object too (the
    #: object's symmetry: its grasps turn with it) or not (the gripper's: the same handle either way)
    turns_with: bool = False
    #: the scene's object for each of the source's (a skill bound to other objects); absent: the same name
    names: dict = field(default_factory=dict)
    released: bool = False  # whether it closed the gripper and opened it again by its end (a place)
    told: bool = False  # whether the members' ends told the goal's frame apart (else the relation's own)

    def scene(self, name):
        """The object of the scene that stands for the source's object ``name``."""
        return self.names.get(name, name)


@dataclass
class _Source:
    id: int
    start: dict  # object -> its position at the demonstration's start
    actions: np.ndarray | None
    segments: list = field(default_factory=list)
    robot: str | None = None  # the arm it was recorded on, where the recording says
    pose_of: str | None = None  # the point of that arm its poses are of (metadata["pose_of"]), if said
    arm: int = 0  # which arm of a recording of several (metadata["arm_index"]; robosuite's robotK_)
    arms: int = 1  # how many arms its recording has (metadata["arms"])
    recording: tuple = ()  # the recorded episode (file, episode): the arms of one recording share it


def _pose(demo, obj, k):
    return np.asarray(demo[f"{obj}_pos"][k], float), np.asarray(demo[f"{obj}_quat"][k], float)


def _moved(p, q, frame_from, frame_to):
    """The pose ``(p, q)`` moved rigidly with a frame from ``frame_from`` to ``frame_to`` (each ``(p, q)``):
    ``T_to · T_from⁻¹ · T``. ``p`` may be (n, 3) with ``q`` (n, 4)."""
    turn = quaternion_multiply(frame_to[1], quaternion_conjugate(frame_from[1]))
    p = frame_to[0] + (np.asarray(p, float) - frame_from[0]) @ quaternion_to_matrix(turn).T
    return p, quaternion_multiply(np.broadcast_to(turn, np.shape(q)), q)


def _in_frame(demo, relation, frame):
    """Where the primitive ends in ``frame`` (of its own samples), or None if it lacks the frame's object.

    For a carried object, where the *object* ends, as the tool let it go (:func:`_let_go`): the tool's
    place on it depends on how it was grasped.
    """
    carried = relation is not None and relation.moves_with
    end = np.asarray(demo[f"{relation.object}_pos"][_let_go(demo)] if carried else demo["position"][-1],
                     float)
    if frame == ("world",):
        return end
    pose = _frame_at(demo, relation, frame)
    return None if pose is None else quaternion_to_matrix(pose[1]).T @ (end - pose[0])


def _frame_at(demo, relation, frame):
    """The pose ``(p, q)`` of an object ``frame`` in the primitive's own samples (:func:`_source_frame`),
    or None without it."""
    obj, at = frame
    name = relation.target if at == "target" else obj
    if name is None or f"{name}_pos" not in demo.streams:
        return None
    return _source_frame(demo, relation, frame)


def _told_apart(members, frames, spread) -> bool:
    """Whether the members' data can tell their candidate frames apart.

    Two frames give different spreads of the same ends only as far as the frames themselves differ from
    member to member: where the object stood still (pieces of one halting approach to one cube, which
    settled by a millimetre), its frame and the world's are one frame shifted, and their spreads differ
    by that millimetre, decided by noise (59.90 against 59.76 mm). The frames are told apart when the
    object frames, placed at the members' mean end, vary more than the ends do in the best frame.
    """
    world = np.array([e for m in members if (e := _in_frame(m.primitive.demo, m.relation, ("world",)))
                      is not None])
    if len(world) < 2:
        return False
    centre, best = world.mean(0), min(spread)
    for frame in frames:
        if frame == ("world",):
            continue
        poses = [x for m in members if (x := _frame_at(m.primitive.demo, m.relation, frame)) is not None]
        at = np.array([quaternion_to_matrix(q).T @ (centre - p) for p, q in poses])
        if len(at) > 1 and float(np.sqrt(((at - at.mean(0)) ** 2).sum(1).mean())) > best:
            return True
    return False


def _sits(demo, obj) -> np.ndarray:
    """Where ``obj`` sits in the tool's frame at each sample of ``demo``: constant while it is held as
    grasped, whatever the wrist does."""
    R = quaternion_to_matrix(np.asarray(demo["orientation"], float))
    return np.einsum("nji,nj->ni", R, np.asarray(demo[f"{obj}_pos"], float) - demo["position"])


def _held_until(demo, obj) -> int:
    """The last sample at which the carried ``obj`` is still where the tool holds it (a segment that ends
    with a release lets it fall after that)."""
    offset = _sits(demo, obj)
    held = np.flatnonzero(np.linalg.norm(offset - offset[0], axis=1) <= HELD)
    return int(held[-1]) if len(held) else len(offset) - 1


def _let_go(demo) -> int:
    """The sample at which a carrying segment puts its object where it goes: the first of its last opening
    command (a place), else its last sample (a lift keeps holding).

    Where the object went, which the frames of a skill's members are judged by, is where the tool let it
    go, not where it last sat exactly as grasped (:func:`_held_until`): a can creeps by two centimetres in
    the fingers over a carry, which ends that hold a few samples after the lift, near where it was picked
    up; judged there, ten places in the same quarter of a bin agreed best relative to the pick-up.
    """
    commands = np.asarray(demo["actions"][:, 6], float)
    if not _released(demo):
        return len(commands) - 1
    return int(np.flatnonzero(commands > 0)[-1]) + 1


def _slack(demo, obj) -> float:
    """How far the carried ``obj`` moved in the hand over the source's carry, until it was let go (m).

    A planned move keeps what the hand holds this much clearer of the scene (:class:`ArmScene`'s
    ``slack``): it is planned with the object as it sits in the hand when the move begins, and a can that
    creeps down between the fingers by two centimetres, as its demonstrations show, is carried over a
    bin's wall a centimetre lower than planned, where its bottom catches the wall and it is pulled out
    of the fingers.
    """
    offset = _sits(demo, obj)[:_let_go(demo) + 1]
    return float(np.linalg.norm(offset - offset[0], axis=1).max())


def _turn_reference(demo, relation, turn):
    """The source orientation the tool's end orientation is kept relative to (None: the world)."""
    if turn == "held":
        return np.asarray(demo["orientation"][0], float)
    if turn == ("world",):
        return None
    return _source_frame(demo, relation, turn)[1]


def _end_heading(demo, relation, turn):
    ref = _turn_reference(demo, relation, turn)
    # the heading of the x axis about the vertical: a tool pointing down, an object standing on the table
    return _yaw(demo["orientation"][-1]) - (0.0 if ref is None else _yaw(ref))


def _candidate_frames(relation, released=False):
    """The frames a segment's goal may be kept in, its relation's own first (kept where the data cannot
    tell them apart: one demonstration).

    A carry that lets its object go near no other object (``released``) puts it on what the scene holds
    fixed (a peg, a bin, a place on the table): the world, in which the fixtures stand, comes first. A
    carry that keeps holding (a lift) is relative to where the object was picked up.
    """
    if relation is None:
        return [("world",)]
    if not relation.moves_with:
        return [(relation.object, "end"), ("world",)]
    frames = [("world",), (relation.object, "start")] if released else [(relation.object, "start"),
                                                                         ("world",)]
    if relation.target is not None:
        frames.insert(0, (relation.object, "target"))
    return frames


def _released(demo) -> bool:
    """Whether the segment ``demo`` closed the gripper and opened it by its end (a place)."""
    commands = np.asarray(demo["actions"][:, 6], float)
    return bool(commands[-1] <= 0 < commands.max())


def _signature(relation):
    return None if relation is None else (relation.object, relation.moves_with, relation.target)


def _choose_frames(sources):
    """Each segment's frames, where its skill's members end most consistently.

    The goal position's frame: the candidate in which the members' end positions spread least. The
    goal orientation's: the candidate (the tool's own start orientation, the position's frame, the
    world) and the symmetry (quarter, half or whole turns about the vertical) in which the members' end
    headings agree best: the circular concentration ``|mean(exp(i k theta))|``, the smaller ``k`` on a
    tie. A grasp of a cube is kept to a quarter turn of its faces, a carry holds the wrist as it was, a
    square nut ends square to its peg.
    """
    groups = {}
    for src in sources:
        for seg in src.segments:
            # one arm's members only: two arms' reaches may be one skill (each for its handle of a pot),
            # but each arm ends where it does on the object, and they would blur each other's frame
            key = (seg.primitive.cluster, _signature(seg.relation), src.arm)
            groups.setdefault(key, []).append(seg)
    for members in groups.values():
        frames = _candidate_frames(members[0].relation, members[0].released)
        spread = []
        for frame in frames:
            ends = [_in_frame(m.primitive.demo, m.relation, frame) for m in members]
            ends = np.array([e for e in ends if e is not None])
            # one member says nothing about consistency: keep the relation's own frame (the first)
            spread.append(float(np.sqrt(((ends - ends.mean(0)) ** 2).sum(1).mean())) if len(ends) > 1
                          else math.inf)
        # one member, or members whose frames did not move apart, say nothing about which frame is kept:
        # the relation's own (the first: the object it ends at, the carried object's target or start)
        told = np.isfinite(spread).any() and _told_apart(members, frames, spread)
        best = frames[int(np.argmin(spread))] if told else frames[0]
        turns = ["held"] + ([best] if best != ("world",) else []) + [("world",)]
        # one member: a place on what the scene holds fixed keeps the object's orientation there (a nut
        # square to its peg); a grasp keeps the tool's orientation on the object (MimicGen's transform);
        # the turns either may take are the scene's to say (:func:`_in_scene`); anything else keeps the
        # wrist as it was
        first = members[0].relation
        place = members[0].released and best == ("world",) and _carries(first)
        grasp = first is not None and not first.moves_with and best == (first.object, "end")
        choice, score = ((("world",), 1) if place else (best, 1) if grasp else ("held", 1)), -1.0
        if len(members) > 1:
            for turn in turns:
                theta = np.array([_end_heading(m.primitive.demo, m.relation, turn) for m in members])
                for k in SYMMETRIES:
                    concentration = round(float(abs(np.exp(1j * k * theta).mean())), 2)
                    if concentration > score:
                        choice, score = (turn, k), concentration
        turns_with = choice[1] > 1 and choice[0] == best and _turns_with(members, best, choice[1])
        for m in members:
            m.frame, (m.turn, m.symmetry), m.turns_with, m.told = best, choice, turns_with, bool(told)


def _carries(relation) -> bool:
    return relation is not None and relation.moves_with


def _turns_with(members, frame, k) -> bool:
    """Whether a symmetric turn of the members' grasp turns the tool's place on the object with it.

    A heading that repeats every ``2 pi / k`` is the gripper's symmetry when the members' ends in
    ``frame`` agree clearly better as they are than turned back by each one's own turn (a square nut's
    handle taken with the fingers either way round: 5 mm as they are, 6 cm turned back): the place
    stays. Otherwise it is the object's (a box taken from either side), and a turned grasp is the
    demonstration's grasp of the turned object, its approach included: the approach is turned with the
    tool, so the place turns with it. Where the ends are at the demonstrator's noise (grasps at the
    centre, a few millimetres apart) they cannot tell the two apart, and the place turns with the
    approach (measured: kept, 14/20 on each of two unloading libraries; turned, 17/20 and 18/20).
    """
    raw, back = [], []
    for m in members:
        end = _in_frame(m.primitive.demo, m.relation, frame)
        if end is None:
            continue
        angle = 2 * math.pi / k * round(k * _end_heading(m.primitive.demo, m.relation, frame) / (2 * math.pi))
        raw.append(end)
        back.append(_about_vertical(end, -angle))
    if len(raw) < 2:
        return False

    def spread(ends):
        ends = np.asarray(ends, float)
        return float(np.sqrt(((ends - ends.mean(0)) ** 2).sum(1).mean()))

    return not spread(raw) < TURNS_WITH * spread(back)


def _sources(store):
    prims = store.primitives()
    if not prims:
        raise ValueError(f"{store.location}: the library holds no primitives; add demonstrations first")
    by_demo = {}
    for p in prims:
        by_demo.setdefault(p.demonstration_id, []).append(p)
    demos = store.demonstrations(sorted(by_demo))
    sources = []
    for demo_id, ps in sorted(by_demo.items()):
        demo = demos[demo_id]
        objects = object_streams(demo)
        missing = [s for s in ("position", "orientation", "actions") if s not in demo.streams]
        if not objects or missing:
            raise ValueError(f"{store.location}: demonstration {demo_id} records "
                             f"{'no object poses' if not objects else 'no ' + ', '.join(missing)}; "
                             "sim evaluate needs demonstrations with the tool pose, the actions and the "
                             "objects' poses (record them with 'skillbank sim record')")
        if demo["actions"].shape[1] != 7:
            raise ValueError(f"{store.location}: demonstration {demo_id}'s actions have "
                             f"{demo['actions'].shape[1]} columns; expected robosuite's 7 (OSC pose deltas "
                             "and the gripper) of a one-arm robot")
        meta = demo.metadata
        src = _Source(demo_id, {o: np.asarray(demo[f"{o}_pos"][0], float) for o in objects},
                      np.asarray(demo["actions"], float), robot=recorded_robot(demo),
                      pose_of=meta.get(POSE_OF), arm=arm_of(meta) or 0,
                      arms=1 if arm_of(meta) is None else meta["arms"],
                      recording=(str(meta.get("source")), str(meta.get("demo", meta.get("episode")))))
        for p in sorted(ps, key=lambda p: p.start):
            relation = acted_on(p.demo)
            released = _released(p.demo)
            src.segments.append(_Segment(p, relation, _candidate_frames(relation, released)[0],
                                         released=released))
        sources.append(src)
    _choose_frames(sources)
    return [part for src in sources for part in _parts(src)]


def _parts(src) -> list:
    """``src`` cut into one source per object it picks and places, or ``[src]`` if it moves one.

    A demonstration that moves several objects (a PickPlace of all four, both nuts) is several parts, each
    the reach for one object, its carry and what follows until the next object is reached for; a part
    knows only the objects it acts on (the one carried and where it is put), so that a task with that
    object alone runs it and a composed task binds it. The segments keep their samples of the whole
    demonstration (a replay plays its actions).
    """
    parts = []  # [object, carried, segments]
    for seg in src.segments:
        r = seg.relation
        obj = None if r is None else r.object
        if parts and (obj is None or obj == parts[-1][0] or not parts[-1][1] or parts[-1][0] is None):
            parts[-1][0] = parts[-1][0] or obj
        else:
            parts.append([obj, False, []])
        parts[-1][1] = parts[-1][1] or bool(r is not None and r.moves_with and r.object == parts[-1][0])
        parts[-1][2].append(seg)
    if len(parts) < 2:
        return [src]
    out = []
    for obj, _, segments in parts:
        acted = {obj} | {s.relation.target for s in segments
                         if s.relation is not None and s.relation.moves_with}
        acted.discard(None)
        out.append(replace(src, start={o: src.start[o] for o in sorted(acted) if o in src.start},
                           segments=segments))
    return out


def _spelled(name: str) -> str:
    """robosuite's spelling of one of its arms (``ur5e`` -> ``UR5e``); any other name as it is."""
    try:
        return robosuite_robot(name)
    except ValueError:
        return name


def driven_robot(sources, robot: str = DRIVEN_ROBOT) -> dict:
    """Which arm runs (``robot``), which the library was recorded on (``recorded_on``: the names its
    sources say, sorted; empty where none says), and a note when they differ (names compared in any case).
    """
    recorded = sorted({_spelled(s.robot) for s in sources if s.robot is not None}, key=str.lower)
    other = [r for r in recorded if r.lower() != robot.lower()]
    notes = [f"library recorded on {' and '.join(recorded)}; driven on {robot}"] if other else []
    # a demonstration of several objects is several parts (sources) of one id
    arms = {s.id: s.robot for s in sources}
    unknown = sum(arm is None for arm in arms.values())
    if unknown and recorded:
        notes.append(f"{unknown} of the library's {len(arms)} demonstrations say no arm")
    return {"robot": robot, "recorded_on": recorded, "notes": notes}


def running_arm(sources, robot: str = DRIVEN_ROBOT) -> dict:
    """:func:`driven_robot` with notes on how the sources' poses are taken on ``robot``
    (:func:`~skillbank.simulation._arms.pose_points`, which raises for a point it cannot take). Called
    before an episode runs, so a library the arm cannot run costs no simulation."""
    arm = driven_robot(sources, robot)
    return {**arm, "notes": arm["notes"] + pose_points(sources, robot)}


class _Fingers(NamedTuple):
    """The executing gripper, and the scene's objects as its pads meet them."""

    axis: np.ndarray  # the closing axis in the tool's frame
    half: float  # half the opening, m
    pad: float  # half a pad's width across the closing axis, m
    extents: dict  # object -> its half sizes (m) in its own frame (:func:`object_extents`)


def _fingers(env, obs):
    """The gripper's :class:`_Fingers`, from its finger pads' collision geoms, and the objects' extents."""
    across = _pads(env)
    width = float(np.linalg.norm(across))
    R = quaternion_to_matrix(np.asarray(obs["robot0_eef_quat"], float))
    axis = R.T @ (across / max(width, 1e-9))
    return _Fingers(axis, width / 2, pad_half_width(env, R @ axis),
                    {o: object_extents(env, o) for o in _objects(obs)})


def _grasped(seg, fingers):
    """``(object, its half extents)`` of the scene object a reach that closes the gripper closes on, or
    None: another segment, no gripper said, or an object the scene does not model."""
    relation = seg.relation
    if (fingers is None or relation is None or relation.moves_with
            or seg.primitive.demo["actions"][-1, 6] <= 0):
        return None
    obj = seg.scene(relation.object)
    half = fingers.extents.get(obj)
    return None if half is None else (obj, half)


def _half_extent(obs, obj, half, direction) -> float:
    """The scene object ``obj``'s half extent (m) along the world ``direction`` (unit), from its half
    sizes ``half`` along its own axes as it lies in ``obs``."""
    return float(np.abs(quaternion_to_matrix(np.asarray(obs[f"{obj}_quat"], float)).T @ direction) @ half)


def _on_pads(seg, obs, p, q, fingers) -> np.ndarray:
    """The goal ``p`` of a reach that closes the gripper on its object, moved across the closing axis
    just enough that the executing gripper's pads overlap the object's face by their width.

    A person grasps off centre (2.75 cm across a 4 cm cube's face, the Panda's 1.6 cm pads still
    closing on its edge); the grasp kept where it was on the object leaves another gripper's pads on
    nothing but the corner, and the cube turns out of the fingers. Along the closing axis nothing
    moves (closing centres the object between the fingers); across it the offset is kept as far as the
    pads still cover the face (centred, if the face is narrower than a pad).
    """
    grasped = _grasped(seg, fingers)
    if grasped is None:
        return p
    obj, half = grasped
    R = quaternion_to_matrix(q)
    up = R[:, 2]
    across = np.cross(up, R @ fingers.axis)  # along a pad's width, in the world
    across /= max(float(np.linalg.norm(across)), 1e-12)
    centre = np.asarray(obs[f"{obj}_pos"], float)
    reach = _half_extent(obs, obj, half, across)
    room = max(0.0, reach - fingers.pad)
    off = float((centre - p) @ across)
    return p + (off - np.clip(off, -room, room)) * across


def _spans(seg, obs, q, fingers) -> bool:
    """Whether the executing gripper's open fingers, at orientation ``q``, span the object a reach that
    closes the gripper closes on (its extent along the closing axis, from its collision geoms, within
    the opening); True for any other segment, or where the scene does not say.

    A heading the members teach may repeat where the object does not: ten grasps of a cereal box, nine
    across its 3 cm side and one a quarter round, agree best at quarter turns, and a quarter-turned goal
    closes the fingers across the box's 10 cm side, which the 2F-85's 9.5 cm between its pads cannot
    span: the fingers land on the box's top.
    """
    grasped = _grasped(seg, fingers)
    if grasped is None:
        return True
    obj, half = grasped
    closing = quaternion_to_matrix(q) @ fingers.axis
    return _half_extent(obs, obj, half, closing) < fingers.half


def _cost(segments, obs, fingers=None) -> float:
    """How far the segments' goals move in the scene ``obs`` shows: the size of the adaptation.

    A goal's change counts its distance plus :data:`LEVER` metres per radian of its turn (a wrist
    that turns much as it closes in sweeps its fingers through what it reaches for).
    """
    total = 0.0
    for seg in segments:
        p, q = _goal(seg, obs, fingers)
        demo = seg.primitive.demo
        total += float(np.linalg.norm(p - demo["position"][-1]))
        if q is not None:
            total += LEVER * float(quaternion_angle(q, demo["orientation"][-1]))
    return total


def _nearest(sources, obs, fingers=None):
    """The source whose segments' goals move least in this scene (:func:`_cost`)."""
    return min(sources, key=lambda src: _cost(src.segments, obs, fingers))


def _samplers(sampler):
    """Every leaf placement sampler under ``sampler`` (robosuite's composite samplers hold others)."""
    inner = getattr(sampler, "samplers", None)
    if inner is None:
        return [sampler]
    return [leaf for s in inner.values() for leaf in _samplers(s)]


def _reseed(env, seed):
    # robosuite 1.5 draws the placement and the robot's initial noise from env.rng, which the samplers
    # made at the first load hold a reference to: every holder gets the episode's generator
    env.rng = np.random.default_rng(seed)
    for s in _samplers(env.placement_initializer):
        s.rng = env.rng
    if hasattr(env.placement_initializer, "rng"):
        env.placement_initializer.rng = env.rng


def _widen(env, half_width):
    for s in _samplers(env.placement_initializer):
        if getattr(s, "name", "") == "HideSampler" or not hasattr(s, "x_range"):
            continue
        for axis in ("x_range", "y_range"):
            lo, hi = (float(v) for v in getattr(s, axis))
            c = (lo + hi) / 2
            setattr(s, axis, [c - half_width, c + half_width])


class _Contacts:
    """Which arm links (not the gripper) touch anything that is not the robot, read from MuJoCo."""

    def __init__(self, env):
        model = env.sim.model
        # a geom without a name (robosuite's bins) goes by its body's
        names = [model.geom_id2name(i) or model.body_id2name(model.geom_bodyid[i]) or f"geom {i}"
                 for i in range(model.ngeom)]
        # the arm's own prefix (robot1_ for the second arm of a two-arm task): another arm is scene to it
        k = env.robots[0].robot_model.naming_prefix[len("robot"):-1]
        self.arm = np.array([n.startswith(f"robot{k}_") for n in names])
        self.robot = np.array([n.startswith((f"robot{k}_", f"gripper{k}_", f"mount{k}_", f"fixed_mount{k}_"))
                               for n in names])
        self.names, self.data = names, env.sim.data._data

    def touching(self):
        n = self.data.ncon
        if n == 0:
            return None
        g1, g2 = self.data.contact.geom1[:n], self.data.contact.geom2[:n]
        hit = (self.arm[g1] & ~self.robot[g2]) | (self.arm[g2] & ~self.robot[g1])
        if not hit.any():
            return None
        k = int(np.argmax(hit))
        return f"{self.names[g1[k]]} touched {self.names[g2[k]]}"


class _Episode:
    def __init__(self, env, obs, horizon, trace=False, reach=None):
        """Adapted segments also leave as their demonstrations did (:func:`_path_adapted`): a lift off
        the table stays a lift, clear of a cube beside the one picked up (a human Stack, tuning seeds:
        17/20 on the UR5e without, 19/20 with); ``reach``: a
        :class:`~skillbank.simulation._reach.Reach` that keeps commanded paths within the arm's reach
        margin (a composed task, whose arm goes on from where each step leaves it)."""
        self.env, self.horizon = env, horizon
        self.path = [] if trace else None
        self.driver = _Driver(env, obs, keep=False)
        self.steps, self.success, self.contact, self.segment = 0, False, None, 0
        self.contacts = _Contacts(env)
        self.reach = reach

    @property
    def obs(self):
        return self.driver.obs

    def step(self, target, quat=None, grip=None, posture=None):
        """One control step towards the tool pose ``target``, ``quat``; ``posture``: the joints a planned
        move passes through there (:meth:`_Driver.posture`)."""
        if quat is not None:
            self.driver.quat = np.asarray(quat, float)
        if grip is not None:
            self.driver.grip = grip
        if posture is not None:
            self.driver.posture(posture)
        self.driver.step(target)
        self._after()

    def act(self, action):
        self.driver.obs = with_object_poses(self.env, self.env.step(np.asarray(action, float))[0])
        self._after()

    def _after(self):
        self.steps += 1
        if self.path is not None:
            self.path.append(np.array(self.obs["robot0_eef_pos"], float))
        if self.contact is None:
            touch = self.contacts.touching()
            if touch is not None:
                self.contact = (self.segment, touch)
        self.success = self.success or bool(self.env._check_success())

    @property
    def over(self):
        return self.success or self.steps >= self.horizon

    def rest(self, objects, *, most=2 * CONTROL_FREQ, still=0.5e-3):
        """Hold still until no object moves more than ``still`` metres in a step (at most ``most`` steps).

        robosuite places objects above their resting height (a nut falls 6 cm after a reset): the scene
        is read once it is at rest, as a person looks before reaching.
        """
        def hold():
            self.act(np.r_[np.zeros(6), self.driver.grip])
            return self.obs

        _at_rest(hold, self.obs, objects, most=most, still=still)

    def settle(self, goal, quat):
        for _ in range(SETTLE):
            if self.over or np.linalg.norm(goal - self.obs["robot0_eef_pos"]) < ARRIVE:
                break
            self.step(goal, quat)


def _grip(commands):
    return np.where(np.asarray(commands, float) > 0, 1.0, -1.0)


def _frame_pose(obs, seg, frame):
    """The pose in the scene ``obs`` shows of the segment's frame ``frame`` (its object, bound)."""
    obj, at = frame
    name = seg.scene(seg.relation.target if at == "target" else obj)
    return np.asarray(obs[f"{name}_pos"], float), np.asarray(obs[f"{name}_quat"], float)


def _source_frame(demo, relation, frame):
    """The frame's pose in the source primitive: the target at its end, the carried object at its start,
    the object a reach ends at where it stood as the hand came (:func:`_stood`)."""
    obj, at = frame
    if at == "target":
        return _pose(demo, relation.target, -1)
    if at == "start":
        return _pose(demo, obj, 0)
    reached = relation is not None and not relation.moves_with and obj == relation.object
    return _pose(demo, obj, _stood(demo, obj) if reached else -1)


def _stood(demo, obj) -> int:
    """The sample of the reach ``demo`` at which ``obj`` stood as it did while the hand came: the one
    nearest its median position over the reach.

    Not the reach's last sample: the closing fingers push what they grasp (a milk carton centred between
    the pads by a centimetre), and the way in, kept relative to the carton where it ended, comes down a
    centimetre off where the carton stands in a new scene, onto its top edge. Not its first either: an
    object dropped into place at reset settles for the first few samples.
    """
    where = np.asarray(demo[f"{obj}_pos"], float)
    return int(np.argmin(np.linalg.norm(where - np.median(where, axis=0), axis=1)))


def _goal_orientations(seg, obs):
    """The tool's goal orientations ``[(q, angle)]``: the source's end orientation kept relative to the
    segment's turn frame, and its symmetric turns (by ``angle`` about the vertical), nearest to the tool's
    orientation now first."""
    demo, relation = seg.primitive.demo, seg.relation
    here = np.asarray(obs["robot0_eef_quat"], float)
    q = np.asarray(demo["orientation"][-1], float)
    if relation is not None and relation.moves_with and seg.turn != "held":
        # what the frame keeps is the carried object's orientation (a nut square to its peg), and the tool
        # holds the object as it holds it now: its grasp in this scene need not be the source's
        k = _held_until(demo, relation.object)
        goal = _pose(demo, relation.object, k)[1]
        if seg.turn != ("world",):
            goal = quaternion_multiply(_frame_pose(obs, seg, seg.turn)[1], quaternion_multiply(
                quaternion_conjugate(_source_frame(demo, relation, seg.turn)[1]), goal))
        held = np.asarray(obs[f"{seg.scene(relation.object)}_quat"], float)
        q = quaternion_multiply(goal, quaternion_multiply(quaternion_conjugate(held), here))
    else:
        ref = _turn_reference(demo, relation, seg.turn)
        if ref is not None:
            now = here if seg.turn == "held" else _frame_pose(obs, seg, seg.turn)[1]
            q = quaternion_multiply(now, quaternion_multiply(quaternion_conjugate(ref), q))
    options = [(_turn(q, 2 * math.pi * m / seg.symmetry), 2 * math.pi * m / seg.symmetry)
               for m in range(seg.symmetry)]
    return sorted(options, key=lambda o: float(quaternion_angle(o[0], here)))


def _goal_position(seg, obs, q, angle=0.0):
    """The tool's goal position in the scene ``obs`` shows, with the tool at orientation ``q``, the
    source's end orientation turned by ``angle`` about the vertical (a symmetric turn)."""
    demo, relation = seg.primitive.demo, seg.relation
    if relation is not None and relation.moves_with:
        # the carried object goes where it went in the source, relative to the frame; the tool holds it
        # as it holds it now (a grasp a few millimetres off moves the tool, not the object)
        k = _held_until(demo, relation.object)
        end = _object_goal(seg, obs)
        here_p, here_q = np.asarray(obs["robot0_eef_pos"], float), np.asarray(obs["robot0_eef_quat"], float)
        held = quaternion_to_matrix(here_q).T @ (np.asarray(obs[f"{seg.scene(relation.object)}_pos"], float)
                                                 - here_p)
        # and then moves as the source's tool did after letting go (nothing, when it let go at the end)
        return end - quaternion_to_matrix(q) @ held + (demo["position"][-1] - demo["position"][k])
    if seg.frame == ("world",):
        return np.asarray(demo["position"][-1], float)
    p_obj, q_obj = _frame_pose(obs, seg, seg.frame)
    # the source's end moved with the frame: its relation's pose on the frame, as the frame stood
    p = _moved(demo["position"][-1], demo["orientation"][-1], _source_frame(demo, relation, seg.frame),
               (p_obj, q_obj))[0]
    if angle and seg.turns_with:
        # the tool turned with the object's symmetry grasps the object from the other side: where it is
        # relative to the object turns with it (else a grasp a centimetre off the centre on one side
        # is two centimetres off on the other, the clearance a finger has beside a thin box)
        p = p_obj + _about_vertical(p - p_obj, angle)
    return p


def _object_goal(seg, obs) -> np.ndarray:
    """Where the object a carrying segment holds is let go in the scene ``obs`` shows: where the source's
    was, in the segment's frame."""
    demo, relation = seg.primitive.demo, seg.relation
    end = _pose(demo, relation.object, _held_until(demo, relation.object))[0]
    if seg.frame != ("world",):
        end = _moved(end, np.array([0.0, 0.0, 0.0, 1.0]), _source_frame(demo, relation, seg.frame),
                     _frame_pose(obs, seg, seg.frame))[0]
    return end


def _aimed(obs, obj, held, p, q) -> np.ndarray:
    """How far to shift the tool's last stretch, which lets the carried ``obj`` go at the pose ``p``, ``q``,
    so that the object comes down where the path put it, as the object sits in the hand now.

    The path was planned with the object at ``held`` in the tool's frame (where it sat when the carry
    began). A held object turns and slides a little in the fingers while the wrist turns and the arm
    brakes (a nut hanging from its handle pivots by degrees, a centimetre at its centre): the shift is
    where the path meant the object to be let go less where it would be, as it sits now, with the tool
    at ``p``. The aim is the path's own, whichever executor chose its goal (a skill's frame in ``sim
    evaluate``, a plan step's binding in a composed task).
    """
    tool = np.asarray(obs["robot0_eef_pos"], float)
    there = np.asarray(obs[f"{obj}_pos"], float) + (np.asarray(p, float) - tool)
    return np.asarray(p, float) + quaternion_to_matrix(np.asarray(q, float)) @ held - there


def _gap(obs, obj) -> float:
    """The distance (m) from the tool to ``obj``'s centre."""
    return float(np.linalg.norm(np.asarray(obs[f"{obj}_pos"], float)
                                - np.asarray(obs["robot0_eef_pos"], float)))


def _lost(gap0, gap1) -> bool:
    """Whether an object whose distance to the tool went from ``gap0`` to ``gap1`` has left the hand."""
    return abs(gap1 - gap0) > CARRIED + ARRIVED


def _in_hand(obs, obj, held) -> bool:
    """Whether ``obj``, which sat at ``held`` in the tool's frame when its carry began, is still in the
    hand, by the test a carry's end has (:func:`_check`)."""
    return not _lost(float(np.linalg.norm(held)), _gap(obs, obj))


def _about_vertical(v, angle) -> np.ndarray:
    """The vector ``v`` turned by ``angle`` about the vertical, as :func:`_turn` turns an orientation."""
    return quaternion_to_matrix(_turn([0.0, 0.0, 0.0, 1.0], angle)) @ np.asarray(v, float)


def _goal(seg, obs, fingers=None, reachable=None):
    """The tool's goal pose in the scene ``obs`` shows.

    Of the symmetric orientations, those the arm can take (``reachable(p, q)``, where given: a wrist
    turned past its last joint's limit cannot), the nearest turn whose fingers (``fingers``: the closing
    axis in the tool's frame and half the opening, m) stay :data:`NEIGHBOUR` metres from every object
    the segment does not act on; else the one that keeps them farthest.
    """
    options = [(q, _on_pads(seg, obs, _goal_position(seg, obs, q, angle), q, fingers))
               for q, angle in _goal_orientations(seg, obs)]
    if reachable is not None and len(options) > 1:
        options = [o for o in options if reachable(o[1], o[0])] or options
    if len(options) > 1:
        options = [o for o in options if _spans(seg, obs, o[0], fingers)] or options
    if fingers is None or len(options) == 1:
        return options[0][1], options[0][0]
    others = _others(seg, obs)
    if not others:
        return options[0][1], options[0][0]
    clear = [o for o in options if _room(o[1], o[0], fingers, others) >= NEIGHBOUR]
    q, p = clear[0] if clear else max(options, key=lambda o: _room(o[1], o[0], fingers, others))
    return p, q


def _others(seg, obs) -> list:
    """The centres of the objects the segment does not act on."""
    mine = set() if seg.relation is None else {seg.scene(seg.relation.object),
                                               seg.scene(seg.relation.target)}
    return [np.asarray(obs[f"{o}_pos"], float) for o in _objects(obs) if o not in mine]


def _room(p, q, fingers, others) -> float:
    """How far (m) the fingertips of the tool at ``p``, ``q`` are from the nearest of ``others``."""
    axis, half = fingers.axis, fingers.half
    tips = p + np.outer([-half, half], quaternion_to_matrix(q) @ axis)
    return min((float(np.linalg.norm(tip - o)) for tip in tips for o in others), default=math.inf)


def _path_rigid(seg, obs):
    """The recorded segment moved rigidly into its frame's new pose (MimicGen's transform)."""
    demo = seg.primitive.demo
    P, Q = np.asarray(demo["position"], float), np.asarray(demo["orientation"], float)
    if seg.frame != ("world",):
        # the same frame poses the adapted goals use (for an object the tool reaches, where it lies at the
        # segment's end: robosuite drops objects into place while the first segment starts)
        P, Q = _moved(P, Q, _source_frame(demo, seg.relation, seg.frame), _frame_pose(obs, seg, seg.frame))
    here_p, here_q = np.asarray(obs["robot0_eef_pos"], float), np.asarray(obs["robot0_eef_quat"], float)
    s = np.linspace(0.0, 1.0, RIGID_BLEND + 1)[1:, None]
    blend_p = here_p + s * (P[0] - here_p)
    blend_q = slerp([0.0, 1.0], np.stack([here_q, Q[0]]), s[:, 0])
    grip = _grip(demo["actions"][:, 6])
    return (np.vstack([blend_p, P]), np.vstack([blend_q, Q]),
            np.concatenate([np.full(RIGID_BLEND, grip[0]), grip]))


def _adapted_from(seg):
    """The samples of a segment's primitive that its path is adapted from: a reach from its last try
    (:func:`_last_try`), anything else whole."""
    demo = seg.primitive.demo
    if seg.relation is not None and not seg.relation.moves_with:
        demo = demo.slice(_last_try(demo), demo.n_steps)
    return demo


def _control_times(t):
    """The control steps' times over the span of times ``t`` (at least two)."""
    n = max(2, int(round((t[-1] - t[0]) * CONTROL_FREQ)) + 1)
    return np.linspace(t[0], t[-1], n)


def _grip_at(commands, t, ts):
    """The gripper commands ``commands``, spread evenly over the span of ``t``, at times ``ts``."""
    src_t = np.linspace(t[0], t[-1], len(commands))
    return _grip(commands[np.clip(np.searchsorted(src_t, ts), 0, len(commands) - 1)])


def _path_adapted(seg, obs, method, random_state, fingers=None, reachable=None):
    """The primitive adapted by ``method`` from the robot's pose to the scene's goal, at the control rate.

    A reach is adapted from its last try (:func:`_last_try`): a grasp the person closed on nothing and
    opened again is not part of the skill, and replayed by another gripper, whose fingers reach lower,
    it closes on the object and pushes it away.
    """
    demo = _adapted_from(seg)
    goal_p, goal_q = _goal(seg, obs, fingers, reachable)
    # the second half closes in as the source did: its path moved rigidly so that its end is the goal,
    # pinned by via points; the first half is the representation's to adapt from where the robot is
    P_src = np.asarray(demo["position"], float)
    turn = quaternion_to_matrix(quaternion_multiply(goal_q, quaternion_conjugate(demo["orientation"][-1])))
    u_src = (demo.t - demo.t[0]) / max(demo.t[-1] - demo.t[0], 1e-12)
    close = _carried_path(seg, obs, demo, goal_q) if _carries(seg.relation) else \
        goal_p + (P_src - P_src[-1]) @ turn.T
    via = [ViaPoint(np.array([np.interp(u, u_src, close[:, j]) for j in range(3)]), phase=u)
           for u in CLOSE_IN]
    # and the first part leaves as the source did, from where the robot is: a lift off the table stays a
    # lift, clear of what stands beside what was picked up
    here_p, here_q = np.asarray(obs["robot0_eef_pos"], float), np.asarray(obs["robot0_eef_quat"], float)
    off = quaternion_to_matrix(quaternion_multiply(here_q, quaternion_conjugate(demo["orientation"][0])))
    at = [np.array([np.interp(u, u_src, P_src[:, j]) for j in range(3)]) for u in LEAVE]
    via = [ViaPoint(here_p + off @ (a - P_src[0]), phase=u) for a, u in zip(at, LEAVE, strict=True)] + via
    # a primitive of a few samples puts two phases on one sample (or on its start or end): one pin each
    pins = {}
    for v in via:
        pins.setdefault(v.sample(len(demo.t)), v)
    via = [v for k, v in pins.items() if 0 < k < len(demo.t) - 1]
    constraints = Constraints(start=np.asarray(obs["robot0_eef_pos"], float), goal=goal_p, via=via,
                              start_orientation=np.asarray(obs["robot0_eef_quat"], float),
                              goal_orientation=goal_q)
    result = reuse([demo], constraints, method=method, random_state=random_state)
    traj = result.trajectory
    t = np.asarray(traj.t, float)
    ts = _control_times(t)
    P = np.column_stack([np.interp(ts, t, traj["position"][:, j]) for j in range(3)])
    Q = _oriented(seg, obs, (ts - ts[0]) / max(ts[-1] - ts[0], 1e-12), goal_q)
    commands = traj["actions"][:, 6] if "actions" in traj.streams else demo["actions"][:, 6]
    return P, Q, _grip_at(commands, t, ts)


def _recorded_joints(seg, env, n):
    """The joints the source's arm had along the segment, at ``n`` samples spread over it as its adapted
    path is (a reach from its last try, as :func:`_path_adapted` adapts it); None where the source was
    recorded on another arm or records no joints."""
    demo = seg.primitive.demo
    if "robot0_joint_pos" not in demo.streams or recorded_robot(demo) != env.robots[0].name:
        return None
    J = np.asarray(_adapted_from(seg)["robot0_joint_pos"], float)
    return J[np.round(np.linspace(0, len(J) - 1, n)).astype(int)]


def _jointed(seg, env, obs):
    """``(chain,)`` for a segment that carries a part of an articulated object in the scene (a door's
    handle): the joints the source moved it about (:func:`~skillbank.segmentation.part_joints`; None
    where it did not move it); None for any other segment."""
    if not _carries(seg.relation) or not articulated(env, obs, seg.scene(seg.relation.object)):
        return None
    return (part_joints(seg.primitive.demo, seg.relation.object),)


def _path_articulated(seg, obs, chain):
    """``(values, grip, chain, slip)``: a part of an articulated object moved about its joints as the source
    moved it, from where the hand holds it now.

    A part goes where its joints let it: the source's tool path, moved rigidly into a new scene, would
    pull the handle off its arc by as much as this grasp differs from the source's. The joints the source
    moved the part about (``chain``, found from its recorded poses) are carried to where their anchor
    (the door) stands now; ``values`` (one row per control step, one column per joint) are the source's,
    the part's joint in its parent stretched to reach the angle the source reached
    (:func:`_catch_up`); ``slip``, how the source's hand moved on the part (positions and turns in the
    tool's frame, against its grip as the carry began: the fingers give, and a person's hand led the
    lever by a quarter of a turn); the tool, as it holds the part now, moved on it as the source's did
    and turned about the joints (:func:`_drive_jointed`). A part the source did not move (``chain``
    None) is held where it is. The gripper's commands are the source's.
    """
    demo = seg.primitive.demo
    t = np.asarray(demo.t, float)
    ts = _control_times(t)
    grip = _grip_at(demo["actions"][:, 6], t, ts)
    if chain is None:
        return np.zeros((len(ts), 0)), grip, None, None
    stretch = _catch_up(demo, obs, seg, chain) if len(chain.joints) > 1 else 1.0
    values = np.column_stack([np.interp(ts, t, j.values) * (stretch if k == 0 else 1.0)
                              for k, j in enumerate(chain.joints)])
    # how the source's hand moved on the part (its fingers gave; the hand led the lever): the tool in the
    # part's frame, against where it held it as the carry began, at each control step
    part = chain.part
    Rp = quaternion_to_matrix(demo[f"{part}_quat"])
    grip_p = np.einsum("nji,nj->ni", Rp, np.asarray(demo["position"], float) - demo[f"{part}_pos"])
    grip_q = quaternion_multiply(quaternion_conjugate(demo[f"{part}_quat"]), demo["orientation"])
    back = quaternion_conjugate(grip_q[0])
    shift_q = quaternion_multiply(np.broadcast_to(back, grip_q.shape), grip_q)
    shift_p = (grip_p - grip_p[0]) @ quaternion_to_matrix(back).T
    at = np.clip(np.searchsorted(t, ts), 0, len(t) - 1)
    anchor = chain.anchor
    here = seg.scene(anchor)
    now = (np.asarray(obs[f"{here}_pos"], float), np.asarray(obs[f"{here}_quat"], float))
    return values, grip, chain.moved_with((demo[f"{anchor}_pos"][0], demo[f"{anchor}_quat"][0]), now), \
        (shift_p[at], shift_q[at])


def _drive_jointed(episode, seg, values, grip, chain, slip):
    """Turn the tool about a part's joints through ``values`` (:func:`_path_articulated`), leading the part
    by as much as it lags; the tool's last commanded position.

    The fingers give: a lever pressed by a hand that only went where the source's hand went stops short
    of where the latch lets go (0.17 rad of 0.97 on the human-like door). Each step the part's own
    joint values are read from the scene (:meth:`~skillbank.segmentation.PartJoints.measure`) and the
    hand is sent ahead of the source's value by a lead that grows with the part's lag (an integral
    action: a proportional one leaves the lever short by what its spring holds back), at most a quarter
    of the joint's demonstrated travel (a part held back by something else is not wrenched). The values
    are followed at the pace the part keeps: while one joint lags behind by more than a tenth of its
    travel the path waits for it, so the joints keep the order the source moved them in (the lever held
    down until its door is past the frame). Once the values are spent, the hand goes on leading until
    the part is where the source left it or past it. It gives up when the path has waited a second for
    a part that has not moved (a door held shut by what the hand cannot move); the episode's horizon
    bounds the rest.
    """
    obs = episode.obs
    start = _chain_poses(obs, seg, chain)
    p0, q0 = np.asarray(obs["robot0_eef_pos"], float), np.asarray(obs["robot0_eef_quat"], float)
    travel = values[np.argmax(np.abs(values), axis=0), np.arange(values.shape[1])]  # signed, per joint
    most = 0.25 * np.abs(travel)
    # a tenth of each joint's travel; a joint the source's values do not move (its part already past
    # where the source took it) holds nothing up
    tenth = np.where(np.abs(travel) > 1e-9, 0.1 * np.abs(travel), np.inf)
    lead = np.zeros(len(travel))
    p = p0
    at, last = 0.0, len(values) - 1  # where along the source's values the part is being taken
    seen = []  # where along the path and the part's joint values, the last second of them
    while not episode.over:
        j = int(at)
        want = values[j] + (at - j) * (values[min(j + 1, last)] - values[j])
        measured = chain.measure(start, _chain_poses(episode.obs, seg, chain))
        lag = (want - measured) * np.sign(travel)
        if at >= last and np.all(lag <= 0.0):
            # where the source left it, or past it (a lever the door's swing pressed further): not a
            # little short of it, where a door the source opened just past what the task asks is not
            break
        # the source's values are a path through the joints, taken at the pace the part follows: while
        # one joint lags behind by a tenth of its travel the others wait for it (a latch still pressed
        # while its door is being pulled past the frame), then the path goes on at the source's pace
        pace = float(np.clip(1.0 - np.max(np.maximum(lag, 0.0) / tenth), 0.0, 1.0))
        seen = (seen + [np.r_[at, measured]])[-CONTROL_FREQ:]
        span = np.ptp(seen, axis=0)
        if len(seen) == CONTROL_FREQ and span[0] < 1.0 and np.all(span[1:] <= 0.01 * np.abs(travel)):
            break  # waited a second for a part that has not moved: held by what the hand cannot move
        at = min(last, at + pace)
        # the lead grows while the part lags and shrinks as it catches up (a person pushes on until the
        # lever is where they want it): no lag left once the part is there, whatever holds it back
        lead = np.clip(lead + 0.5 * lag, 0.0, most)
        ahead = want + np.sign(travel) * lead
        k = int(round(at))
        p = p0 + quaternion_to_matrix(q0) @ slip[0][k]
        q = quaternion_multiply(q0, slip[1][k])
        for joint, v in zip(chain.joints, ahead, strict=True):
            p, q = joint.move(p, q, v)
        episode.step(p, q, grip[min(k, len(grip) - 1)])
    return p


def _chain_poses(obs, seg, chain):
    """``{name: (position, quaternion)}`` of a chain's part and anchor (the source's names) in the scene
    ``obs`` shows, as :meth:`~skillbank.segmentation.PartJoints.measure` takes them."""
    return {k: (np.asarray(obs[f"{seg.scene(k)}_pos"], float), np.asarray(obs[f"{seg.scene(k)}_quat"], float))
            for k in (chain.part, chain.anchor)}


def _catch_up(demo, obs, seg, chain):
    """The factor on the source's values of a part's joint in its parent (a handle's latch in its door)
    that brings it to the same angle in the parent as the source brought it to, from where it stands now.

    The source's hand had already pressed the lever a little as its fingers closed (0.3 rad in a
    person's demonstration): turned by as much again, a lever that stands at rest in a new scene stops
    short of where the latch lets go. How far the part stands in its parent now past where the source's
    stood as its carry began is the chain's own measure of its inner joint
    (:meth:`~skillbank.segmentation.PartJoints.measure`, the source's poses against this scene's); the
    values are stretched so that their furthest reaches the source's furthest angle.
    """
    source = {k: (demo[f"{k}_pos"][0], demo[f"{k}_quat"][0]) for k in (chain.part, chain.anchor)}
    ahead = float(chain.measure(source, _chain_poses(obs, seg, chain))[0])
    values = np.asarray(chain.joints[0].values, float)
    furthest = float(values[np.argmax(np.abs(values))])
    if abs(furthest) < 1e-6:
        return 1.0
    return max(0.0, (furthest - ahead) / furthest)


def _carried_path(seg, obs, demo, goal_q):
    """The tool's path (one position per source sample) that takes the carried object along the path the
    source took it, moved into the segment's frame, as the tool holds it now.

    It is the object that must clear what it passes and come down on its place: held the other way
    round (a nut picked up from its other side, a symmetric turn of the place), the tool's own recorded
    path would bring the object down on the peg's top. After the source let go, the tool moves as the
    source's did.
    """
    obj = seg.relation.object
    k = _held_until(demo, obj)
    path = np.asarray(demo[f"{obj}_pos"], float)
    if seg.frame != ("world",):
        path = _moved(path, np.tile([0.0, 0.0, 0.0, 1.0], (len(path), 1)),
                      _source_frame(demo, seg.relation, seg.frame), _frame_pose(obs, seg, seg.frame))[0]
    Q = np.asarray(demo["orientation"], float)
    turn = quaternion_multiply(goal_q, quaternion_conjugate(Q[-1]))
    here_p, here_q = np.asarray(obs["robot0_eef_pos"], float), np.asarray(obs["robot0_eef_quat"], float)
    held = quaternion_to_matrix(here_q).T @ (np.asarray(obs[f"{seg.scene(obj)}_pos"], float) - here_p)
    R = quaternion_to_matrix(quaternion_multiply(np.broadcast_to(turn, Q.shape), Q))
    tool = path - R @ held
    P = np.asarray(demo["position"], float)
    tool[k + 1:] = tool[k] + (P[k + 1:] - P[k])
    return tool


def _in_scene(seg, env):
    """``seg`` with the turns about the vertical of its goal that the scene says change nothing, where
    its data teach none (one demonstration, or members that agree at whole turns: a cube is still taken
    the same way at a quarter turn, whatever its demonstrations happened to show).

    A place on what the scene holds fixed may take any turn the fixture there accepts
    (:func:`support`: a square peg, a quarter turn) or the placed object's own geometry does (a carton
    in a bin, a half turn). A grasp kept on the object may take the object's
    turns (:func:`object_symmetry`: a cube's quarter turns, the tool's place on it turning with it), else
    the gripper's: two opposed pads close the same way half a turn round (a nut's handle taken from its
    other side, the place on the handle kept).
    """
    relation = seg.relation
    if seg.released and not seg.told and seg.frame == (getattr(relation, "object", None), "target") \
            and not _rests_on(seg, env):
        # let go beside the object it ended nearest, not on it: it was put on what the scene holds fixed
        # there (a bin's compartment), which the world keeps, as a place near no object is
        seg = replace(seg, frame=("world",), turn=("world",))
    if seg.symmetry != 1 or seg.turn == "held":
        return seg
    if seg.released and seg.frame == ("world",) and seg.turn == ("world",) and _carries(relation):
        demo = seg.primitive.demo
        held = support(env, _pose(demo, relation.object, _held_until(demo, relation.object))[0])
        # the object's own turns leave its place unchanged too (a carton in a bin: its half turns)
        return seg if held is None else replace(
            seg, symmetry=math.lcm(held[1], object_symmetry(env, seg.scene(relation.object))))
    if relation is not None and not relation.moves_with and seg.turn == seg.frame == (relation.object, "end"):
        k = object_symmetry(env, seg.scene(relation.object))
        return replace(seg, symmetry=k, turns_with=True) if k > 1 else \
            replace(seg, symmetry=2, turns_with=False)
    return seg


def _rests_on(seg, env) -> bool:
    """Whether the object ``seg`` carries was let go, in its source, on top of the relation's target:
    its centre over the target's footprint and above its top (the target's collision geometry in the
    scene, along its own axes, :func:`object_extents`). True where the scene does not model the target
    (the relation's own frame is kept)."""
    relation, demo = seg.relation, seg.primitive.demo
    extents = object_extents(env, seg.scene(relation.target))
    if extents is None:
        return True
    p, _ = _pose(demo, relation.object, _held_until(demo, relation.object))
    pt, qt = _pose(demo, relation.target, -1)
    local = quaternion_to_matrix(qt).T @ (p - pt)
    return bool(np.all(np.abs(local[:2]) <= extents[:2]) and local[2] > extents[2])


def _last_try(demo) -> int:
    """The sample a reach's last try begins at: after the last time its gripper command opened again
    (a grasp that held nothing: the phases put it inside the reach), if a try of at least half a
    second follows; else 0."""
    closed = np.asarray(demo["actions"][:, 6], float) > 0
    reopened = np.flatnonzero(closed[:-1] & ~closed[1:]) + 1
    if reopened.size and demo.n_steps - reopened[-1] >= CONTROL_FREQ // 2:
        return int(reopened[-1])
    return 0


def _over_tops(P, G, env, obs, carried=None):
    """The path ``P`` with its travel lifted over the tops of what stands in the scene: neither an open
    hand nor what a closed one carries sweeps through an object or a fixture.

    The first half of an adapted segment (before :data:`CLOSE_IN`, where the demonstration's own close-in
    is pinned) is the representation's, from where the robot is, and knows nothing of the scene: from the
    robot's start it can cross a tall box at the height of its top and knock it over before coming down
    on it, and a nut carried a centimetre lower than its demonstration catches the peg's top. There, while
    the gripper is open or carries the scene's object ``carried``, a sample within horizontal reach of an
    object's or a fixture's box (:func:`fixtures`: a peg, a bin) is raised so that the fingertips, and
    the bottom of what they hold, pass :data:`OVER` above its top (the boxes, the hand's and the held
    object's reach and depth below the tool point are MuJoCo's collision geoms as they lie now); the raise
    is widened and smoothed over a quarter second, so the hand rises before it comes over the object. What
    the tool starts within reach of (the table, what was just let go of) is left as the demonstration
    leaves it.
    """
    G = np.asarray(G)
    travel = (np.arange(len(P)) < CLOSE_IN[0] * (len(P) - 1)) & (G <= 0)
    if carried is not None:
        travel |= G > 0
    if not travel.any():
        return P
    sim = env.sim
    tool = np.asarray(obs["robot0_eef_pos"], float)
    hand_lo, hand_hi = _box(sim, _gripper(env).contact_geoms)
    boxes = []
    centre = None  # the held object's centre at each sample
    for model in env.model.mujoco_objects:
        if f"{model.name}_pos" not in obs or not model.contact_geoms:
            continue
        if model.name == carried:  # it travels with the hand
            lo, hi = _box(sim, model.contact_geoms)
            hand_lo, hand_hi = np.minimum(hand_lo, lo), np.maximum(hand_hi, hi)
            centre = P + (np.asarray(obs[f"{carried}_pos"], float) - tool)
        else:
            boxes.append(_box(sim, model.contact_geoms))
    boxes += [_box(sim, geoms) for geoms in fixtures(env).values()]
    depth = tool[2] - hand_lo[2]
    reach = float(np.abs(np.r_[hand_lo[:2] - tool[:2], hand_hi[:2] - tool[:2]]).max())
    floor = np.full(len(P), -np.inf)
    for lo, hi in boxes:
        def gap(xy, lo=lo, hi=hi):  # horizontal distance to the object's box
            return np.linalg.norm(np.maximum(0.0, np.maximum(lo[:2] - xy, xy - hi[:2])), axis=-1)

        if gap(tool[:2]) < reach:
            continue
        over = travel & (gap(P[:, :2]) < reach)
        if centre is not None:
            # what a held object comes down onto (a nut onto its peg, a cube onto the other) does not keep
            # it above once its centre is over it: there the demonstration's own descent is pinned
            over &= ~((G > 0) & (gap(centre[:, :2]) == 0))
        floor[over] = np.maximum(floor[over], hi[2] + depth + OVER)
    lift = np.where(np.isfinite(floor), np.maximum(0.0, floor - P[:, 2]), 0.0)
    if not lift.any():
        return P
    from scipy.ndimage import maximum_filter1d, uniform_filter1d  # only a path that needs a raise

    width = 2 * (CONTROL_FREQ // 4) + 1
    # a running maximum, then a running mean no wider: never below the raise asked for, and smooth
    smooth = uniform_filter1d(maximum_filter1d(lift, width, mode="nearest"), width, mode="nearest")
    out = np.array(P, float)
    out[:, 2] += np.maximum(smooth, lift)
    return out


def _oriented(seg, obs, u, goal):
    """The tool's orientation at phases ``u``: the source's rotation profile turned to end at ``goal``,
    the robot's start orientation blended into it over the first half (minimum jerk).

    The wrist turns to the new frame while it travels, and closes in on the goal the way the
    demonstration did: a correction spread over the whole path would still be turning the fingers
    as they reach what they grasp.
    """
    demo = seg.primitive.demo
    src = slerp(demo.t, demo["orientation"], demo.t[0] + u * (demo.t[-1] - demo.t[0]))
    turn = quaternion_multiply(goal, quaternion_conjugate(src[-1]))
    src = quaternion_multiply(np.broadcast_to(turn, src.shape), src)
    here = np.asarray(obs["robot0_eef_quat"], float)
    offset = quaternion_multiply(here, quaternion_conjugate(src[0]))
    w = 1.0 - _min_jerk_at(np.clip(2.0 * u, 0.0, 1.0))
    turns = exp_map(w[:, None] * log_map(offset)[None, :])
    return quaternion_multiply(turns, src)


def _check(seg, before, episode):
    """The failure reason of a segment that just ran, or None."""
    obs = episode.obs
    relation = seg.relation
    if relation is not None and relation.moves_with:
        obj = seg.scene(relation.object)
        gap0, gap1 = _gap(before, obj), _gap(obs, obj)
        travel = np.linalg.norm(obs[f"{obj}_pos"] - before[f"{obj}_pos"])
        if _lost(gap0, gap1):
            if travel < 0.01:
                if seg.primitive.demo["actions"][0, 6] <= 0:
                    # an open gripper leaves what it let go of: a retreat whose demonstration dragged the
                    # object up a little while the fingers opened is not a grasp to miss
                    return None
                return "missed grasp", f"{obj} stayed where it was ({gap1:.3f} m from the tool)"
            # a segment that ends with the gripper open lets the object go: where it went is for the
            # task's check (or a plan step's effect) to judge, not a drop
            if seg.primitive.demo["actions"][-1, 6] > 0:
                return "dropped", f"{obj} is {gap1:.3f} m from the tool, {gap0:.3f} m when the segment began"
    return None


def _run_segments(episode, segments, actions, method, random_state, timings, misses=None, planner="none",
                  gate=None):
    """Run ``segments`` (of one source, whose recorded ``actions`` replay uses); ``(index, reason, detail)``
    of the first failure, or None. With a list ``misses``, a tool that stops short of a segment's goal is
    noted there instead of being a failure. ``planner="ompl"``: each adapted segment's free span is
    planned for the whole arm where its path would bring a body near the scene
    (:func:`~skillbank.simulation._transit.free_move`). ``gate(i)``: called before segment ``i`` begins
    (an arm of several waits there for the others, :func:`_evaluate_arms_episode`)."""
    let_go = False  # whether the last segment opened the gripper: what follows only leaves
    for i, seg in enumerate(segments):
        if episode.over:
            break
        episode.segment = i
        if gate is not None:
            gate(i)
            if episode.over:
                break
        before = {k: np.array(v, float) for k, v in episode.obs.items() if isinstance(v, np.ndarray)}
        goal = None  # the tool's, where the segment was adapted (replay has none)
        if method == "replay":  # the source's own actions over the segment's samples, open loop
            steps0 = episode.steps
            for action in actions[seg.primitive.start:seg.primitive.stop]:
                if episode.over:
                    break
                episode.act(action)
        else:
            tic = time.perf_counter()
            carried = None  # the scene's name of what the segment carries (None: nothing, or a rigid path)
            jointed = chain = None  # the joints of a part of an articulated object the segment moves
            postures = None  # the joints of a planned move at each of its samples
            try:
                if method == "rigid":
                    P, Q, G = _path_rigid(seg, episode.obs)
                else:
                    seg = _in_scene(seg, episode.env)
                    jointed = _jointed(seg, episode.env, episode.obs)
                    if jointed is not None:  # a door's handle: about its joints, never through free space
                        values, G, chain, slip = _path_articulated(seg, episode.obs, jointed[0])
                        P = np.tile(np.asarray(episode.obs["robot0_eef_pos"], float), (len(G), 1))
                        Q = np.tile(np.asarray(episode.obs["robot0_eef_quat"], float), (len(G), 1))
                    else:
                        P, Q, G = _path_adapted(seg, episode.obs, method, random_state, episode.fingers,
                                                reachable(episode.env, episode.obs))
                        carried = seg.scene(seg.relation.object) if _carries(seg.relation) else None
                        P = _over_tops(P, G, episode.env, episode.obs, carried)
            except ValueError as error:
                return i, "unreachable", str(error).splitlines()[0]
            if episode.reach is not None:
                P = episode.reach.keep(P, Q, episode.obs["robot0_joint_pos"],
                                       need=episode.reach.needed(G, let_go=let_go))
            if planner == "ompl" and method != "rigid":
                # a part of an articulated object is moved about its joints all the way: no free space
                span = None if jointed is not None else free_span(len(P), G, let_go=let_go,
                                                                  close_in=CLOSE_IN[0])
                try:
                    P, Q, G, report = (P, Q, G, None) if span is None else free_move(
                        episode.env, episode.obs, P, Q, G, span, random_state=random_state,
                        held=carried if G[span[0]] > 0 else None,
                        slack=_slack(seg.primitive.demo, seg.relation.object) if carried else 0.0,
                        recorded=_recorded_joints(seg, episode.env, len(P)))
                except MotionPlanningError as error:
                    return i, "no transit", str(error).splitlines()[0]
                if report is not None and report["planned"]:
                    timings.setdefault("transits", []).append(round(report["seconds"], 4))
                    postures = [None] * len(P)
                    first = report["span"][0] + 1
                    postures[first:first + len(report["joints"])] = list(report["joints"])
            let_go = bool(G[-1] <= 0 < G.max())
            timings["adapt"] += time.perf_counter() - tic
            steps0 = episode.steps
            shift = np.zeros(3)
            held = None  # where the carried object sits in the tool's frame as the path was planned
            if carried is not None:
                here = episode.obs
                held = quaternion_to_matrix(np.asarray(here["robot0_eef_quat"], float)).T @ (
                    np.asarray(here[f"{carried}_pos"], float) - np.asarray(here["robot0_eef_pos"], float))
            if jointed is not None and chain is not None:  # in closed loop about the part's joints
                goal = _drive_jointed(episode, seg, values, G, chain, slip)
                P, Q, G = P[:0], Q[:0], G[:0]
            for k, (p, q, g) in enumerate(zip(P, Q, G, strict=True)):
                if episode.over:
                    break
                if g != episode.driver.grip and g <= 0 and held is not None and _in_hand(episode.obs, carried,
                                                                                       held):
                    # about to let go of what it carries: aimed again from where it sits in the hand now
                    # (not from where a dropped object lies: the arm would swing across the scene after it;
                    # where it fell is the task's check to judge)
                    shift = _aimed(episode.obs, carried, held, p, q)
                p = p + shift
                if g != episode.driver.grip:
                    # the gripper acts where the path says, once the tool is there: the controller trails
                    # its commands by centimetres on a fast descent, and fingers closed on time but short
                    # of the can push it away instead of holding it
                    episode.settle(p, q)
                episode.step(p, q, g, posture=None if postures is None else postures[k])
            if len(P):
                episode.settle(P[-1] + shift, Q[-1])
                goal = P[-1] + shift
        timings["driven"] += (episode.steps - steps0) / CONTROL_FREQ
        if episode.success:
            return None
        if episode.steps >= episode.horizon:
            return i, "timeout", f"the horizon of {episode.horizon} steps ran out in this segment"
        reason = _check(seg, before, episode)
        if reason is not None:
            return (i, *reason)
        if goal is not None:
            far = float(np.linalg.norm(goal - episode.obs["robot0_eef_pos"]))
            if far > ARRIVED:
                if misses is None:
                    return i, "unreachable", f"the tool stopped {far:.3f} m from the segment's goal"
                # the caller judges by what the segments were for (a plan step's effect), not by the tool
                misses.append(f"segment {i} (primitive {seg.primitive.id}): the tool stopped {far:.3f} m "
                              "from its goal")
    return None


def _order(groups, order):
    """The parts of the task (keys of ``groups``) in the order ``order`` names their objects; without it,
    in the order the library's demonstrations show them (``groups`` in the order its parts first appear:
    one demonstration of several objects, as its demonstrator took them; separate demonstrations, as the
    library holds them)."""
    if order is None:
        return list(groups)
    if isinstance(order, str) or not all(isinstance(o, str) for o in order):
        raise ValueError(f"order: expected a list of object names, got {order!r}")
    part_of = {o: part for part in groups for o in part}
    unknown = [o for o in order if o not in part_of]
    if unknown:
        raise ValueError(f"order: the library's demonstrations move no object {unknown}; they move "
                         f"{sorted(part_of)}")
    parts = list(dict.fromkeys(part_of[o] for o in order))
    left = [p for p in groups if p not in parts]
    if left:
        raise ValueError(f"order: it leaves out {sorted(o for p in left for o in p)}; name every object "
                         "the library's demonstrations move")
    return parts


#: The horizon when the demonstrations are short: robosuite's default, 50 s.
DEFAULT_HORIZON = 1000


def _horizon(groups) -> int:
    """Control steps the executor may need to carry out the longest demonstration of every part.

    Each segment runs its demonstrated samples, then waits up to ``SETTLE`` steps to arrive and up to one
    second before a change of the gripper's command; the episode's last second lets the objects settle. A
    person's demonstration is often longer than robosuite's default 1000 steps (a four-object PickPlace:
    7184), so the horizon follows the demonstrations, never below the default.
    """
    need = SETTLE
    for sources in groups.values():
        need += max(sum(seg.primitive.demo.n_steps + SETTLE + CONTROL_FREQ for seg in src.segments)
                    for src in sources)
    return max(DEFAULT_HORIZON, int(need))


def _make(suite, task, seed, horizon, robot=DRIVEN_ROBOT, arms=1):
    if task not in suite.ALL_ENVIRONMENTS:
        raise ValueError(f"env: robosuite has no task {task!r}; its tasks are "
                         f"{sorted(suite.ALL_ENVIRONMENTS)}")
    # hard_reset=False: robosuite then keeps its model and placement samplers across resets, so the
    # widened ranges and the episode's generator stay where they were put
    env = suite.make(task, robots=[robot] * arms, control_freq=CONTROL_FREQ, horizon=horizon, seed=int(seed),
                     has_renderer=False, has_offscreen_renderer=False, use_camera_obs=False,
                     ignore_done=True, reward_shaping=False, hard_reset=False)
    try:
        check_pads(env, robot)
    except ValueError:
        env.close()
        raise
    return env


@dataclass(frozen=True)
class _Evaluation:
    """What every episode of :func:`evaluate` needs, sent to the workers as it is."""

    task: str
    groups: dict
    order: list
    horizon: int
    robot: str
    placement: float | None
    method: str
    random_state: object
    paths: bool
    planner: str = "ompl"  # free spans planned for the whole arm (_transit); "none": as adapted
    arms: int = 1  # the task's arms: with several, each group is the recordings' demonstrations per arm
    sync: bool = True  # whether an arm waits where its recording says it waited for another


def _evaluate_episode(job, seed):
    """``(row, timings)`` of one episode of :func:`evaluate`, in an environment of its own made from ``seed``.

    Nothing outlives the call: the environment is closed, and the random state is the episode's own copy.
    """
    groups, horizon, paths = job.groups, job.horizon, job.paths
    random_state = fresh(job.random_state)
    timings = {"adapt": 0.0, "driven": 0.0, "segments": 0}
    suite = import_robosuite()
    environment = _make(suite, job.task, seed, horizon, job.robot)
    try:
        if job.placement is not None:
            _widen(environment, job.placement)
        _reseed(environment, seed)
        episode = _Episode(environment, environment.reset(), horizon, trace=paths)
        # the parts whose objects the task has: one object's pick and place of a demonstration that
        # moved several runs alone in a task of that object (PickPlaceCan from PickPlace)
        runnable = [part for part in job.order if all(f"{o}_pos" in episode.obs for o in part)]
        if not runnable:
            missing = sorted({o for part in job.order for o in part if f"{o}_pos" not in episode.obs})
            raise ValueError(f"the environment shows no pose of the library's object(s) {missing}; "
                             "evaluate the library in the task it was recorded in")
        objects = sorted({o for part in runnable for o in part})
        episode.rest(objects)
        episode.fingers = _fingers(environment, episode.obs)
        scene = {o: [round(float(v), 6) for v in episode.obs[f"{o}_pos"]] for o in objects}
        # one part of the task after the other (one, unless the library's demonstrations each
        # move other objects), each from the nearest of its sources in the state the last one left
        chain, failure = [], None
        for part in runnable:
            source = _nearest(groups[part], episode.obs, episode.fingers)
            failure = _run_segments(episode, source.segments, source.actions, job.method, random_state,
                                    timings, planner=job.planner)
            timings["segments"] += len(source.segments)
            if failure is not None:
                failure = (len(chain) + failure[0], *failure[1:])
            chain.extend((source, seg) for seg in source.segments)
            if failure is not None or episode.over:
                break
        for _ in range(SETTLE):  # a last second for the objects to come to rest
            if episode.over:
                break
            episode.act(np.r_[np.zeros(6), episode.driver.grip])
    finally:
        environment.close()
    used = list(dict.fromkeys(src.id for src, _ in chain))
    row = {"seed": int(seed), "success": episode.success, "steps": episode.steps,
           "source": used[0], "sources": used, "objects": scene,
           "left_out": sorted({o for part in job.order if part not in runnable for o in part})}
    row["arm_contact"] = None if episode.contact is None else \
        {"segment": episode.contact[0], "detail": episode.contact[1]}
    if paths:
        row["path"] = np.round(np.array(episode.path), 6).tolist()
    if not episode.success:
        if failure is None:
            last = len(chain) - 1
            failure = ((last, "timeout", f"{episode.steps} steps") if episode.steps >= horizon else
                       (last, "misplaced", "the environment's success check fails"))
        i, reason, detail = failure
        reason, detail = _blamed(episode.contact, i, reason, detail)
        row["failure"] = {"segment": i, "primitive": chain[i][1].primitive.id,
                          "source": chain[i][0].id, "reason": reason, "detail": detail}
    return row, timings


def _blamed(contact, i, reason, detail) -> tuple:
    """``(reason, detail)`` of a failure in segment ``i``: a collision when an arm link of the episode hit
    something (``contact``: ``(segment, what touched what)``) on the way to it, for that is what went
    wrong first (not for a timeout)."""
    if contact is not None and contact[0] <= i and reason != "timeout":
        return "collision", f"{contact[1]} in segment {contact[0]}; then {reason}: {detail}"
    return reason, detail


def _arm_recordings(sources, arms: int) -> list:
    """The library's recordings of a task of ``arms`` arms: per recording, its demonstration of each arm,
    in arm order."""
    recordings = {}
    for src in sources:
        recordings.setdefault(src.recording, {}).setdefault(src.arm, []).append(src)
    out = []
    for by_arm in recordings.values():
        ids = sorted({s.id for v in by_arm.values() for s in v})
        if sorted(by_arm) != list(range(arms)):
            raise ValueError(f"the library's demonstration(s) {ids} are of arm(s) {sorted(by_arm)} of a "
                             f"recording of {arms} arms; add every arm's demonstration of it (library add "
                             "reads them all from the recording)")
        if any(len(v) > 1 for v in by_arm.values()):
            raise ValueError(f"the library's demonstrations {ids} move several objects in turn with one arm "
                             "of a two-arm recording; a two-arm task is run from recordings in which each "
                             "arm acts on one object")
        out.append([by_arm[k][0] for k in range(arms)])
    return out


def _at_rest(hold, obs, objects, *, most=2 * CONTROL_FREQ, still=0.5e-3):
    """Call ``hold()`` (one control step holding still; it returns the observations after it) until no
    object of ``objects`` moves more than ``still`` metres in a step, at most ``most`` times; the last
    observations (``obs`` when none was taken)."""
    where = np.array([obs[f"{o}_pos"] for o in objects])
    for _ in range(most):
        obs = hold()
        now = np.array([obs[f"{o}_pos"] for o in objects])
        if np.abs(now - where).max() < still:
            break
        where = now
    return obs


def _arm_spans(src) -> list:
    """The source's segments on its recording's clock, and whether each began holding on."""
    return [ArmSpan(int(seg.primitive.start), int(seg.primitive.stop),
                    bool(src.actions[seg.primitive.start, 6] > 0)) for seg in src.segments]


def _evaluate_arms_episode(job, seed):
    """:func:`_evaluate_episode` for a task of several arms: each arm runs its demonstration of the nearest
    recording in a thread of its own, stepped together (:class:`~skillbank.simulation._lockstep.Lockstep`);
    a segment begins once the other arms have come as far as they had in the recording
    (:func:`~skillbank.segmentation.arm_constraints`; not with ``job.sync`` false)."""
    import threading

    arms = job.arms
    timings = [{"adapt": 0.0, "driven": 0.0, "segments": 0} for _ in range(arms)]
    suite = import_robosuite()
    environment = _make(suite, job.task, seed, job.horizon, job.robot, arms=arms)
    recordings = job.groups
    try:
        if job.placement is not None:
            _widen(environment, job.placement)
        _reseed(environment, seed)
        obs = with_object_poses(environment, environment.reset())
        objects = sorted({o for pair in recordings for src in pair for o in src.start})
        missing = [o for o in objects if f"{o}_pos" not in obs]
        if missing:
            raise ValueError(f"the environment shows no pose of the library's object(s) {missing}; "
                             "evaluate the library in the task it was recorded in")
        obs = _at_rest(lambda: with_object_poses(environment, environment.step(  # every arm holds still
            np.tile(np.r_[np.zeros(6), -1.0], arms))[0]), obs, objects)
        scene = {o: [round(float(v), 6) for v in obs[f"{o}_pos"]] for o in objects}
        lock = Lockstep(environment, obs, arms)
        episodes = []
        for k in range(arms):
            view = ArmEnv(environment, k, lock)
            episode = _Episode(view, arm_obs(lock.obs, k), job.horizon, trace=job.paths)
            episode.fingers = _fingers(view, episode.obs)
            episodes.append(episode)
        pair = min(recordings, key=lambda p: sum(_cost(src.segments, episodes[k].obs, episodes[k].fingers)
                                                 for k, src in enumerate(p)))
        need = arm_constraints([_arm_spans(src) for src in pair]) if job.sync else None
        results, errors = [None] * arms, []

        def run(k):
            episode, src = episodes[k], pair[k]

            def gate(i):
                with lock.cond:
                    lock.reached[k] = i
                if need is None:
                    return
                here = np.array(episode.obs["robot0_eef_pos"], float)
                while not episode.over and not all(lock.reached[a] >= m for a, m in need[k][i].items()):
                    episode.step(here)  # waits where the recording waited: holds still

            try:
                results[k] = _run_segments(episode, src.segments, src.actions, job.method,
                                           fresh(job.random_state), timings[k], planner=job.planner,
                                           gate=gate)
                timings[k]["segments"] += len(src.segments)
                if results[k] is not None:
                    lock.stop()  # one arm failed: the task has
            except Stopped:
                pass
            except BaseException as error:  # re-raised in the caller's thread
                errors.append(error)
                lock.stop()
            finally:
                with lock.cond:
                    lock.reached[k] = len(src.segments)
                lock.done(k, episode.driver.grip)

        threads = [threading.Thread(target=run, args=(k,), name=f"arm {k}") for k in range(arms)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        if errors:
            raise errors[0]
        success = any(e.success for e in episodes)
        steps = lock.steps
        for _ in range(SETTLE):  # a last second for the objects to come to rest
            if success or steps >= job.horizon or lock.stopped:
                break
            environment.step(np.concatenate(lock.rest))
            steps += 1
            success = bool(environment._check_success())
    finally:
        environment.close()
    row = {"seed": int(seed), "success": success, "steps": steps, "source": pair[0].id,
           "sources": [src.id for src in pair], "objects": scene}
    contact = next(((k, e.contact) for k, e in enumerate(episodes) if e.contact is not None), None)
    row["arm_contact"] = None if contact is None else \
        {"arm": contact[0], "segment": contact[1][0], "detail": contact[1][1]}
    if job.paths:
        row["path"] = np.round(np.array(episodes[0].path), 6).tolist()
        row["paths"] = [np.round(np.array(e.path), 6).tolist() for e in episodes]
    if not success:
        failed = next(((k, r) for k, r in enumerate(results) if r is not None), None)
        if failed is None:
            k = int(np.argmax([e.steps for e in episodes]))  # the arm that went on longest
            last = len(pair[k].segments) - 1
            failed = (k, (last, "timeout", f"{steps} steps") if steps >= job.horizon else
                      (last, "misplaced", "the environment's success check fails"))
        k, (i, reason, detail) = failed
        reason, detail = _blamed(episodes[k].contact, i, reason, detail)
        row["failure"] = {"arm": k, "segment": i, "primitive": pair[k].segments[i].primitive.id,
                          "source": pair[k].id, "reason": reason, "detail": detail}
    total = {key: sum(t[key] for t in timings) for key in ("adapt", "driven", "segments")}
    total["transits"] = [x for t in timings for x in t.get("transits", [])]
    return row, total


def evaluate(library, env: str, *, episodes: int = 10, seed: int = 0, placement=None, method: str = "lte",
             horizon: int | None = None, order=None, random_state=None, paths: bool = False,
             progress=None, robot: str = DRIVEN_ROBOT, workers=None, scheduler=None,
             verbose: bool = False, planner: str = "ompl", sync: bool = True) -> dict:
    """Run the library's skills in ``episodes`` new robosuite scenes and count the environment's successes.

    Parameters
    ----------
    library : str, path-like or Store
        The library (its demonstrations record the tool pose, the actions and the objects' poses, as
        ``skillbank sim record`` writes them).
    env : str
        ``robosuite:TASK``, any robosuite task with one arm.
    episodes : int, default=10
        Scenes to run; episode ``k`` is reset from seed ``seed + k``.
    seed : int, default=0
        The first episode's seed.
    placement : float, optional
        Widens every object's x and y placement range to plus or minus this many metres around its
        default centre.
    method : str, default="lte"
        A name of :data:`skillbank.selection.METHODS`, or a baseline of :data:`BASELINES`.
    planner : {"ompl", "none"}, default="ompl"
        ``"ompl"``: the free span of each adapted segment (between the part that leaves as its
        demonstration did and the demonstration's own close-in) is followed for the whole arm in the
        scene's MuJoCo geometry and, where a link, the gripper or a held object would come near the scene,
        planned in joint space by OMPL (:mod:`skillbank.simulation._transit`); a move it cannot plan fails
        the episode with reason ``"no transit"``.
    horizon : int, optional
        Control steps an episode may take (20 per second). Default: what the executor may need to carry
        out the library's longest demonstration of each part (its samples, plus the waits to arrive and
        before each change of the gripper), at least :data:`DEFAULT_HORIZON`.
    order : sequence of str, optional
        When the library's demonstrations each act on other objects (one per object, say), the task is
        done part after part: each part is the demonstrations of one set of objects, run from the
        nearest of them in the state the last part left. ``order`` names the objects in the order
        their parts run (default: the order the demonstrations show them in: a demonstration of several
        objects, its own; separate ones, the library's). With one part, it is not needed.
    random_state : int or None
        Seeds the representation where it samples (ProMP).
    paths : bool, default=False
        Add each episode's tool positions, one per control step (``path``, m), for a figure.
    progress : callable, optional
        ``progress(done, successes)`` after each episode.
    robot : str, default="UR5e"
        robosuite's arm that runs the skills, with its default gripper (any case: ``panda``). The
        library's poses are of its recorded gripper's grip site, which robosuite's observations and
        controller speak of on every arm: the skills run on another arm through the tool's pose (a note
        says so when the library was recorded on another).
    workers : int, optional
        Run the episodes on a new local Dask cluster of this many worker processes (at most 2 per core,
        or ``SKILLBANK_MAX_WORKERS``; the extra ``skillbank[dask]``).
    scheduler : str or distributed.Client, optional
        Run them on an existing Dask cluster, ``tcp://HOST:PORT``, whose workers have ``skillbank[sim]``.
        Each episode builds its own environment from its seed, wherever it runs: the rows are those of a
        run in this process, in seed order (``random_state``: each episode starts from its own copy).
        A worker that dies is replaced and its episode run again; an episode whose workers all died is
        a ValueError naming its seed, and no report is made.
    verbose : bool, default=False
        Let robosuite's log (and a local cluster's) through, on stderr.
    sync : bool, default=True
        For a library of a two-arm task (its demonstrations each of one arm of a recording,
        ``metadata["arm_index"]``): each episode runs every arm's demonstration of the nearest recording
        at once, and a segment of one arm begins only once the others have come as far as they had in the
        recording (:func:`~skillbank.segmentation.arm_constraints`). ``False`` runs the arms without
        waiting for each other, to see what the waits are for. A failure names its ``arm``.

    Returns
    -------
    dict
        ``{"env", "robot", "recorded_on", "notes", "method", "seed", "placement", "horizon", "episodes",
        "successes",
        "success_rate", "interval", "timing", "per_episode"}``: ``robot`` the arm driven
        (``robot``, by default :data:`DRIVEN_ROBOT`, robosuite's UR5e), ``recorded_on`` the
        arms the library's demonstrations say they were recorded on, and a note when that is another;
        each episode's entry has its ``seed``, ``success``, ``steps``,
        ``source`` (the demonstration it followed; ``sources``, one per part), ``objects`` (each
        object's position at rest before the first segment), ``arm_contact`` and, for a failure,
        ``failure`` with the ``segment`` (from 0, counted along every part), its ``primitive`` and
        ``source`` ids, the ``reason`` (a key of :data:`REASONS`) and a ``detail``. With ``workers`` or
        ``scheduler``, ``"scheduler"``: the address of the cluster used.
    """
    if not isinstance(env, str) or not env.startswith("robosuite:") or not env.split(":", 1)[1]:
        raise ValueError(f"env: expected robosuite:TASK, got {env!r}")
    task = env.split(":", 1)[1]
    episodes = check_positive(episodes, name="episodes", integer=True)
    if horizon is not None:
        horizon = check_positive(horizon, name="horizon", integer=True)
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or seed < 0:
        raise ValueError(f"seed: expected a non-negative integer, got {seed!r}")
    if placement is not None:
        placement = check_positive(placement, name="placement")
    if method not in METHODS and method not in BASELINES:
        raise ValueError(f"method: expected one of {sorted(METHODS) + list(BASELINES)}, got {method!r}")
    robot = robosuite_robot(robot)
    planner = check_planner(planner)
    workers = check_episode_cluster(workers, scheduler)  # before the library is read, and no process starts
    store = open_store(library, create=False)
    try:
        sources = _sources(store)
    finally:
        if store is not library:
            store.close()
    arm = running_arm(sources, robot)  # before any episode: a point the arm cannot take is refused
    # as many arms as the recordings have, whichever of them the library holds (one arm's alone is refused)
    arms = max(src.arms for src in sources)
    if arms > 1:  # a task of several arms: each recording's demonstrations, one per arm, run together
        groups = _arm_recordings(sources, arms)
        if planner != "none":
            # a planned move is checked against a still scene, and the other arm moves (OMPL's callbacks
            # into Python from two arms' threads are not safe either): each arm's moves stay as adapted
            arm = {**arm, "notes": arm["notes"] + [f"planner {planner!r} is not used with {arms} arms: each "
                                                   "arm's free moves are followed as adapted"]}
            planner = "none"
        order = []
        if horizon is None:
            # the arms' segments one after the other: an arm may wait for all the other's
            horizon = max(DEFAULT_HORIZON, SETTLE + max(
                sum(seg.primitive.demo.n_steps + SETTLE + CONTROL_FREQ for src in p for seg in src.segments)
                for p in groups))
    else:
        groups = {}
        for src in sources:  # the parts of a task: the sources that act on the same objects
            groups.setdefault(tuple(sorted(src.start)), []).append(src)
        order = _order(groups, order)
        if horizon is None:
            horizon = _horizon(groups)
    job = _Evaluation(task=task, groups=groups, order=order, horizon=horizon, robot=robot,
                      placement=placement, method=method, random_state=random_state, paths=paths,
                      planner=planner, arms=arms, sync=sync)
    # each episode builds its own environment from its seed: the same rows here and on any worker
    results, address = run_episodes(_evaluate_episode if arms == 1 else _evaluate_arms_episode, job,
                                    [int(seed) + k for k in range(episodes)],
                                    workers=workers, scheduler=scheduler, progress=progress, verbose=verbose)
    rows = [row for row, _ in results]
    timings = {key: sum(t[key] for _, t in results) for key in ("adapt", "driven", "segments")}
    # the parts a task without some of the objects left out (a part of one object of a demonstration of
    # several, in a task of the others): said once
    left = sorted({o for row in rows for o in row.pop("left_out", ())})
    if left:
        arm = {**arm, "notes": arm["notes"] + [f"the task has no {left}: their parts of the "
                                               "demonstrations are left out"]}
    successes = sum(r["success"] for r in rows)
    return {"env": env, **arm, "method": method, "seed": int(seed),
            "placement": placement, "horizon": horizon, "episodes": episodes, "successes": successes,
            "success_rate": successes / episodes,
            "interval": list(binomial_interval(successes, episodes)),
            "planner": planner,
            "timing": {"adapt_seconds": timings["adapt"], "driven_seconds": timings["driven"],
                       "segments": timings["segments"],
                       **transit_timing(t.get("transits", []) for _, t in results)},
            "per_episode": rows, **({} if address is None else {"scheduler": address})}
