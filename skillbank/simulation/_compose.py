"""A plan over labelled skills, executed and checked in robosuite: ``skillbank plan LIB --scene robosuite:TASK
--simulate``.

The paper's future work: skills learned from single demonstrations, given
sparse labels and a PDDL description each, composed by a planner into a task
nobody demonstrated, and carried out in physics. Here

1. the scene is read from the simulation at rest: its objects, and the facts
   that hold (:func:`observe`: which object the gripper holds, which stands on
   which or in which place, which are clear);
2. the planner (:func:`skillbank.planning.solve`) finds the actions that make
   the goal true, over the library's described skills; the order of the
   moves the goal leaves free is the world's, chosen before each step: the
   object that stands highest first (:func:`_highest_first`);
3. each action is carried out by a *phase* of a demonstration: the primitives
   that reach for an object, or that carry it and let it go (cut where the
   tool starts and stops carrying, from :func:`~skillbank.selection.acted_on`)
   whose labels (given or inferred) name the action. The objects the phase
   acted on are bound to the action's arguments (``object`` and ``target`` of
   the skill's binding; by default its first and second parameters), and its
   segments run closed loop from the state the last step left, adapted to the
   bound objects' poses as ``sim evaluate`` adapts them (the same frames and
   the same methods);
4. after each step the world is looked at again: the step's planned effect
   must be what the simulation shows, and before each step what the plan
   expects must still hold. A difference stops the execution with its reason
   or, with ``replan``, plans again from the observed facts.

Success is the environment's own check for the whole task (robosuite's
``_check_success()``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from ..core import slerp
from ..core._validation import check_positive
from ..planning import parse_atom, problem_text, skill_domain, solve
from ..planning._binding import check_binding
from ..planning._pddl import atoms_of
from ..robots import MotionPlanningError
from ..selection import METHODS
from ..store import open_store
from ._episodes import check_episode_cluster, fresh, run_episodes
from ._evaluate import (
    BASELINES,
    DRIVEN_ROBOT,
    NEIGHBOUR,
    REASONS,
    SETTLE,
    _cost,
    _Episode,
    _fingers,
    _goal,
    _make,
    _others,
    _reseed,
    _room,
    _run_segments,
    _sources,
    _widen,
    binomial_interval,
    running_arm,
)
from ._reach import Reach
from ._robosuite import CONTROL_FREQ, _min_jerk_at, import_robosuite, robosuite_robot, with_object_poses
from ._stack3 import CUBES, stack3_class
from ._support import object_top
from ._transit import check_planner, move_to, transit_timing

__all__ = ["execute_plan", "COMPOSED", "STEP_REASONS", "observe"]


@dataclass(frozen=True)
class Composed:
    """A robosuite task for composed plans: what it is made of and what its goal asks, as data.

    ``env``: the robosuite environment. ``places``: for a sorting task, the
    environment's attribute that maps an object's name (lower case) to its
    place and the environment's method that tells whether a position is
    *outside* a place (robosuite's ``PickPlace``: ``object_to_id`` and
    ``not_in_bin``); each object ``O`` then has a place ``O_place``.
    ``goal``: ``"sorted"`` (every object in its place) or ``"tower"`` (the
    objects stacked in the order the goal gives, from the top).
    """

    env: str
    goal: str
    places: tuple | None = None


#: The tasks ``plan --scene robosuite:TASK`` knows.
COMPOSED = {
    "PickPlace": Composed(env="PickPlace", goal="sorted", places=("object_to_id", "not_in_bin")),
    "Stack3": Composed(env="Stack3", goal="tower"),
}
#: Why a composed execution stopped (besides the segment reasons of ``sim evaluate``).
STEP_REASONS = {
    **REASONS,
    "not held": "a step that picks an object ended without the gripper holding it",
    "misplaced": "a step that puts an object somewhere ended with it elsewhere, or the environment's check "
                 "fails at the end",
    "world changed": "what the plan expects before a step (its facts so far) no longer holds in the scene",
    "no skill": "no demonstration's phase is labelled like the step's action",
    "no plan": "the planner found no plan from the facts observed",
    "no transit": "with planner 'ompl': no collision-free joint path was found for a free-space move",
}
MAX_REPLANS = 3
TRANSIT_FROM = 0.05  # m: a reach starting farther than this from its demonstration's start goes there first
TRANSIT_SPEED = 0.25  # m/s: the transit's peak speed
TRANSIT_RISE = 0.1  # m: how far above the higher of its two ends a transit goes across
ABOVE = 0.01  # m: an object stands on another when its centre is this much higher and they touch ...
ON_ANGLE = np.radians(37.0)  # ... and the line between their centres is this near the vertical (a cube
# resting 3.4 cm off the centre of another of 4.5 cm is on it; one touching a cube's side is not)


def _task(scene):
    if not isinstance(scene, str) or not scene.startswith("robosuite:"):
        raise ValueError(f"scene: expected robosuite:TASK (TASK one of {sorted(COMPOSED)}), got {scene!r}")
    name = scene.split(":", 1)[1]
    if name not in COMPOSED:
        raise ValueError(f"scene: plans run in robosuite tasks {sorted(COMPOSED)}, got {name!r}")
    return name, COMPOSED[name]


class _World:
    """The facts of a robosuite scene, read from the simulation."""

    def __init__(self, env, spec, obs):
        self.env, self.spec = env, spec
        self.models = {m.name: m for m in env.model.mujoco_objects}
        self.objects = sorted(o for o in self.models if f"{o}_pos" in obs)
        self.places = {} if spec.places is None else {f"{o}_place": o for o in self.objects}

    def inside(self, place, position) -> bool:
        ids, outside = self.spec.places
        key = getattr(self.env, ids)[self.places[place].lower()]
        return not bool(getattr(self.env, outside)(np.asarray(position, float), key))

    def holding(self, obj) -> bool:
        return bool(self.env._check_grasp(gripper=self.env.robots[0].gripper, object_geoms=self.models[obj]))

    def facts(self, obs) -> set:
        held = {o for o in self.objects if self.holding(o)}
        on = set()
        for o in self.objects:
            if o in held:
                continue
            p = np.asarray(obs[f"{o}_pos"], float)
            for t in self.objects:
                if t == o:
                    continue
                dz = p[2] - obs[f"{t}_pos"][2]
                # on it: touching it from above (the line between their centres within ON_ANGLE of the
                # vertical), not leaning on its side
                if dz > ABOVE and np.linalg.norm(p[:2] - obs[f"{t}_pos"][:2]) < dz * np.tan(ON_ANGLE) and \
                        self.env.check_contact(self.models[o], self.models[t]):
                    on.add(("on", (o, t)))
            for place in self.places:
                if self.inside(place, p):
                    on.add(("on", (o, place)))
        below = {a[1] for _, a in on}
        facts = on | {("holding", (o,)) for o in held}
        resting = {a[0] for _, a in on}
        facts |= {("loose", (o,)) for o in self.objects if o not in held and o not in resting}
        facts |= {("clear", (x,)) for x in [*self.objects, *self.places] if x not in below}
        if not held:
            facts.add(("handempty", ()))
        return facts

    def top(self, obj) -> float:
        """The height (m) of the object's highest point as it lies now, from its collision geoms' boxes."""
        return object_top(self.env, obj)

    def pose(self, obs, obj) -> dict:
        return {"position": [round(float(v), 4) for v in obs[f"{obj}_pos"]],
                "quaternion": [round(float(v), 4) for v in obs[f"{obj}_quat"]], "held": self.holding(obj)}

    def move(self, obj, position) -> None:
        """Put ``obj`` at ``position`` (m), at rest: the world changing behind the plan's back."""
        joint = self.models[obj].joints[0]
        sim = self.env.sim
        qpos = np.array(sim.data.get_joint_qpos(joint), float)
        qpos[:3] = position
        sim.data.set_joint_qpos(joint, qpos)
        sim.data.set_joint_qvel(joint, np.zeros(6))
        sim.forward()


#: Facts the simulation shows (:meth:`_World.facts`); a domain's other predicates are the plan's alone.
OBSERVED = ("on", "holding", "loose", "clear", "handempty")


def observe(env, obs, scene="robosuite:PickPlace") -> list:
    """The facts that hold in a robosuite scene, as PDDL atoms (sorted text).

    ``(holding O)`` when robosuite's grasp check finds both finger pads on ``O``; ``(on O T)`` when
    ``O`` touches ``T`` and stands higher (or lies in the place ``T``), and is not held; ``(loose O)``
    when ``O`` is on nothing and not held; ``(clear X)`` when nothing is on ``X``; ``(handempty)``.
    """
    world = _World(env, _task(scene)[1], obs)
    return sorted(_text(a) for a in world.facts(obs))


def _text(atom) -> str:
    pred, args = atom
    return "(" + " ".join([pred, *args]) + ")"


def _goal_atoms(spec, world, goal):
    if goal is not None:
        atoms = [parse_atom(g, f"goal[{k}]") for k, g in enumerate(goal)]
        # PDDL's names are case-insensitive; the scene's keep their case
        known = {o.lower(): o for o in [*world.objects, *world.places]}
        for pred, args in atoms:
            unknown = [a for a in args if a.lower() not in known]
            if unknown:
                raise ValueError(f"goal: ({pred} {' '.join(args)}) names {unknown[0]!r}, which the scene "
                                 f"does not have; its objects are {sorted(known.values())}")
        return [(pred, tuple(known[a.lower()] for a in args)) for pred, args in atoms]
    if spec.goal == "sorted":
        return [("on", (o, f"{o}_place")) for o in world.objects]
    return [("on", (upper, lower)) for upper, lower in zip(CUBES[:-1], CUBES[1:], strict=True)]


def _tower(atoms):
    """The order, from the top, of a goal that stacks every cube in one tower; ValueError otherwise."""
    below = {a[0]: a[1] for p, a in atoms if p == "on"}
    tops = [c for c in below if c not in below.values()]
    if len(tops) != 1 or len(below) != len(CUBES) - 1:
        raise ValueError(f"goal: expected one tower of {list(CUBES)} as (on UPPER LOWER) facts, got "
                         f"{[_text(a) for a in atoms]}")
    order = [tops[0]]
    while order[-1] in below:
        order.append(below[order[-1]])
    if sorted(order) != sorted(CUBES):
        raise ValueError(f"goal: expected one tower of all of {list(CUBES)}, got {order}")
    return tuple(order)


@dataclass
class _Phase:
    """Consecutive segments of a demonstration that reach for one object, or carry it and let it go."""

    source: object  # _Source
    segments: list
    kind: str  # "reach" or "carry"
    object: str | None
    target: str | None
    label: str | None = None


def _phases(source) -> list:
    phases = []
    for seg in source.segments:
        r = seg.relation
        obj = None if r is None else r.object
        last = phases[-1] if phases else None
        if r is not None and r.moves_with:
            if last is not None and last.kind == "carry" and last.object == obj:
                last.segments.append(seg)
                last.target = last.target or r.target
            else:
                phases.append(_Phase(source, [seg], "carry", obj, r.target))
        elif last is not None and (obj is None or obj == last.object):
            last.segments.append(seg)  # a release, a retreat, a closer approach: the same phase
        else:
            phases.append(_Phase(source, [seg], "reach", obj, None))
    for phase in phases:
        labels = {seg.primitive.label for seg in _doing(phase)} - {None}
        # one label names the phase; none, or several (an ambiguity), name nothing
        phase.label = labels.pop() if len(labels) == 1 else None
    return phases


def _doing(phase) -> list:
    """The segments that do what the phase does (for a carry, those that carry): a retreat after the
    release, which clustering may group with the reaches, does not speak for the phase."""
    return [seg for seg in phase.segments if phase.kind != "carry"
            or (seg.relation is not None and seg.relation.moves_with)]


def _agreeing(phases) -> list:
    """The phases, each keeping its label only if it does what its label's skill does (reach, or carry).

    A label is given to one primitive and inferred over its cluster, and a cluster can hold both kinds
    (the short reaches down to a low bread and a can grouped with the carries of a tall milk): the
    inferred members that do the other thing are not that skill. What the skill does is what the phases
    its label was *given* to do (the person's word), else, with the label given to a whole cluster,
    what most of its phases do. The phases that lose their label are left for :func:`_described`.
    """
    given, every = {}, {}
    for ph in phases:
        if ph.label is None:
            continue
        every.setdefault(ph.label, []).append(ph.kind)
        if any(seg.primitive.label_source == "given" for seg in _doing(ph)):
            given.setdefault(ph.label, []).append(ph.kind)
    major = {label: max(set(ks), key=lambda k: (ks.count(k), k == "carry"))
             for label, ks in {**every, **given}.items()}
    return [ph if ph.label is None or ph.kind == major[ph.label] else replace(ph, label=None)
            for ph in phases]


def _described(every, labelled, domain) -> list:
    """The phases no label names, each named by the one described skill it does, if exactly one.

    Clustering can put one skill's primitives in two clusters (the reaches down to a low bread and a
    can apart from those to a tall milk and cereal box); a label given to one names that cluster only.
    The skills' descriptions still tell the rest: a phase of the kind (reach, or carry) the skill's
    labelled phases are, acting on an object, whose recorded gripper does what the skill's holding
    facts say (:func:`_gripper_fits`: open at the start and closed at the end of a pick), does that
    skill. A phase two skills fit is left unnamed: an ambiguity is not a guess.
    """
    kinds = {}
    for ph in labelled:
        kinds.setdefault(ph.label.lower(), set()).add(ph.kind)
    out = []
    for ph in every:
        if ph.label is not None or ph.object is None:
            continue
        fits = [a for a, action in domain.actions.items()
                if ph.kind in kinds.get(a, ()) and _gripper_fits(ph, action)]
        if len(fits) == 1:
            out.append(replace(ph, label=fits[0]))
    return out


def _bound(phase, action, args, binding):
    """``{source object: scene object}`` binding the phase to the step's arguments, or None if it cannot."""
    params = [p for p, _ in action.parameters]
    value = dict(zip(params, args, strict=True))
    obj_param = binding.object or (params[0] if params else None)
    target_param = binding.target or (params[1] if len(params) > 1 else None)
    if phase.object is None or obj_param is None:
        return None
    names = {phase.object: value[obj_param]}
    if phase.target is not None and target_param is not None:
        if phase.target == phase.object:
            return None
        names[phase.target] = value[target_param]
    return names


def _closed(phase, at) -> bool:
    """Whether the phase's recorded gripper command is closed at its first (``at=0``) or last (-1) sample."""
    seg = phase.segments[at]
    k = seg.primitive.start if at == 0 else seg.primitive.stop - 1
    return bool(phase.source.actions[k, 6] > 0)


def _gripper_fits(phase, action) -> bool:
    """The phase's gripper does what the action's holding facts say: closed where the precondition
    holds something (and open where it needs a free hand), closed at the end where the effect does."""
    pre = atoms_of(action.precondition, "precondition")
    eff = atoms_of(action.effect, "effect")
    for atoms, at in ((pre, 0), (eff, -1)):
        for neg, pred, _ in atoms:
            if pred == "holding" and not neg and not _closed(phase, at):
                return False
            if pred == "handempty" and not neg and _closed(phase, at):
                return False
    return True


def _candidates(phases, action, args, binding):
    """The phases that can carry out ``(action args)``, bound; those on the very same objects if any."""
    options = []
    for phase in phases:
        if phase.label is None or phase.label.lower() != action.name or not _gripper_fits(phase, action):
            continue
        names = _bound(phase, action, args, binding)
        if names is not None:
            options.append((phase, names))
    same = [(p, n) for p, n in options if all(k == v for k, v in n.items())]
    return same or options


def _grounded(action, part, args):
    """The action's ``part`` (``"precondition"`` or ``"effect"``) bound to ``args``:
    ``[(negated, (predicate, args))]``."""
    value = dict(zip([p for p, _ in action.parameters], args, strict=True))
    return [(neg, (pred, tuple(value.get(a, a) for a in atom_args)))
            for neg, pred, atom_args in atoms_of(getattr(action, part), f"action {action.name} {part}")]


def _effects(action, args):
    """The action's effect bound to ``args``: ``[(negated, (predicate, args))]``."""
    return _grounded(action, "effect", args)


def _apply(state, effects):
    state = set(state)
    for neg, atom in effects:
        if neg:
            state.discard(atom)
    for neg, atom in effects:
        if not neg:
            state.add(atom)
    return state


def _holds(state, action, args) -> bool:
    """Whether the action's precondition, bound to ``args``, holds in ``state`` (a set of atoms)."""
    return all((atom in state) != neg for neg, atom in _grounded(action, "precondition", args))


def _schedule(domain, state, first, rest, atoms):
    """``first`` then ``rest``, each next the earliest step of ``rest`` whose precondition holds, if that
    reaches the goal ``atoms`` from ``state``; else None."""
    if not _holds(state, domain.actions[first[0]], first[1]):
        return None
    state, order, rest = _apply(state, _effects(domain.actions[first[0]], first[1])), [first], list(rest)
    while rest:
        k = next((k for k, (a, args) in enumerate(rest) if _holds(state, domain.actions[a], args)), None)
        if k is None:
            return None
        act, args = rest.pop(k)
        state = _apply(state, _effects(domain.actions[act], args))
        order.append((act, args))
    return order if all(a in state for a in atoms) else None


def _highest_first(domain, state, queue, atoms, world, room=None):
    """The plan ``queue`` with the step to take next first: of the steps like its first (the same action)
    that could go first with the rest still reaching the goal, the one on the highest-standing object
    among those whose grasp has room.

    The planner leaves free the order of moves the goal does not order (which object of a bin comes out
    first); the world does not. Fingers closing on an object brush what stands beside it, and a tall
    object tips where a low one does not: taking the tallest first (bin picking's top-first rule) leaves
    low neighbours for last, which the fingers clear. But a grasp whose fingers would come within
    :data:`~skillbank.simulation._evaluate.NEIGHBOUR` of another object (``room(action, args)``, m: a box
    standing against a carton, its symmetric turns all closing towards it) waits until a step whose
    grasp has room has been taken, which may be that neighbour's. Ties keep the planner's order.
    """
    head = queue[0][0]
    options = []
    for k, (act, _) in enumerate(queue):
        if act != head:
            continue
        order = _schedule(domain, state, queue[k], queue[:k] + queue[k + 1:], atoms) if k else queue
        if order is not None:
            options.append((k, order))
    if len(options) < 2:
        return queue

    def rank(option):  # a grasp's room is asked only where there is a choice: it adapts the step's phase
        k, _ = option
        act, args = queue[k]
        height = max((world.top(a) for a in args if a in world.models), default=-np.inf)
        return room is not None and room(act, args) < NEIGHBOUR, -height, k

    return min(options, key=rank)[1]


def _lacking(expected, observed, predicates):
    """Facts of the observed predicates that the plan expects and the scene does not show."""
    return sorted(a for a in expected if a[0] in OBSERVED and a[0] in predicates and a not in observed)


def tally(rows) -> tuple:
    """``(successes, {reason: count})`` of episodes' rows (each with ``success`` and, failed, ``failure``)."""
    failures = {}
    for r in rows:
        if not r["success"]:
            failures[r["failure"]["reason"]] = failures.get(r["failure"]["reason"], 0) + 1
    return sum(bool(r["success"]) for r in rows), failures


def _plan(domain, world, facts, goal, search, name):
    objects = {o: "object" for o in [*world.objects, *world.places]}
    init = sorted(a for a in facts if a[0] in domain.predicates)
    problem = problem_text(objects, init, goal, domain=domain.name, name=name)
    # the planner answers in lower case (PDDL's names are case-insensitive): back to the scene's names
    canon = {o.lower(): o for o in objects}
    return [(a.lower(), tuple(canon.get(x.lower(), x) for x in args)) for a, args in
            solve(domain.text, problem, search=search)], problem


def execute_plan(library, scene: str, *, episodes: int = 1, seed: int = 0, goal=None, method: str = "lte",
                 replan: bool = False, horizon: int = 600, placement=None, disturb=None, search="satisficing",
                 random_state=None, paths: bool = False, progress=None, robot: str = DRIVEN_ROBOT,
                 workers=None, scheduler=None, verbose: bool = False, planner: str = "ompl") -> dict:
    """Plan a task over the library's described skills and carry it out in ``episodes`` robosuite scenes.

    Parameters
    ----------
    library : str, path-like or Store
        Demonstrations recorded with ``skillbank sim record`` (tool pose, actions, object poses),
        clustered, with labels and PDDL descriptions (``library label``, ``library describe``).
    scene : str
        ``robosuite:TASK``, TASK a key of :data:`COMPOSED`.
    episodes : int, default=1
        Scenes; episode ``k`` is placed by robosuite's sampler from seed ``seed + k``.
    goal : list of str or callable, optional
        The goal's facts, e.g. ``["(on cubeB cubeA)", "(on cubeA cubeC)"]``; default the task's (every
        object in its place; the cubes A on B on C). A function ``goal(seed)`` gives each episode its own
        (a function of a module, where the episodes run on Dask workers).
    method : str, default="lte"
        How each segment is adapted (:data:`skillbank.selection.METHODS`), or ``"replay"``: the phases'
        recorded actions, open loop, in the planned order (the baseline), or ``"rigid"``.
    replan : bool, default=False
        When a step's effect is not what the scene shows, or the scene no longer shows what the plan
        expects, plan again from the facts observed (up to 3 times) instead of stopping.
    horizon : int, default=600
        Control steps (20 per second) a plan step may take.
    placement : float, optional
        Widens every object's x and y placement range to plus or minus this many metres.
    disturb : dict, optional
        ``{"after": K, "object": NAME, "position": [x, y, z]}``: once step K (from 1) has run and been
        checked, the object is put at the position: the world changing behind the plan's back.
    search : {"satisficing", "optimal"}
        The planner's search (:data:`skillbank.planning.SEARCHES`).
    paths : bool, default=False
        Add each episode's tool positions (``path``, one per control step) and each step's first index.
    robot : str, default="UR5e"
        robosuite's arm that carries the plan out, with its default gripper (any case: ``panda``), as
        :func:`~skillbank.simulation.evaluate`'s: the library's poses are of its recording arm's grip
        site, taken as this arm's (a note says so when it is another arm; a pose of an unknown point
        recorded on another arm is refused before anything runs).
    progress : callable, optional
        ``progress(done, successes)`` after each episode.
    planner : {"ompl", "none"}, default="ompl"
        ``"ompl"``: free-space moves (the transit to a reach's start, each adapted segment's free span)
        are followed for the whole arm in the scene's MuJoCo geometry and planned in joint space by
        OMPL where a link, the gripper or a held object would come near the scene
        (:mod:`skillbank.simulation._transit`), as :func:`~skillbank.simulation.evaluate`'s.
    workers, scheduler, verbose
        The episodes on Dask, as :func:`~skillbank.simulation.evaluate` runs them: each builds its own
        environment from its seed, and the rows are those of a run in this process, in seed order.

    Returns
    -------
    dict
        ``{"scene", "robot", "recorded_on", "notes", "method", "seed", "episodes", "successes",
        "success_rate", "interval", "failures", "per_episode", "timing"}`` (``robot``: the arm driven,
        ``recorded_on``, ``notes``: as :func:`~skillbank.simulation.evaluate`'s); ``failures`` counts
        the reasons (:data:`STEP_REASONS`); each
        episode has its ``seed``, ``success``, ``plan`` (the first, as text), ``replans``, ``steps``
        (per step: ``action``, ``args``, ``planned`` effect, ``observed`` facts of its predicates and
        the poses of its objects, ``source`` and ``primitives``, ``ok``, and for a failure ``reason``
        and ``detail``), ``facts`` (observed at the start and at the end), ``objects`` (at rest,
        before the first step) and, for a failure, ``failure``. With ``workers`` or ``scheduler``,
        ``"scheduler"``: the address of the cluster used.
    """
    name, spec = _task(scene)
    episodes = check_positive(episodes, name="episodes", integer=True)
    horizon = check_positive(horizon, name="horizon", integer=True)
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or seed < 0:
        raise ValueError(f"seed: expected a non-negative integer, got {seed!r}")
    if method not in METHODS and method not in BASELINES:
        raise ValueError(f"method: expected one of {sorted(METHODS) + list(BASELINES)}, got {method!r}")
    if placement is not None:
        placement = check_positive(placement, name="placement")
    if goal is not None and not callable(goal) and (isinstance(goal, str) or not goal
                                                    or not all(isinstance(g, str) for g in goal)):
        raise ValueError(f"goal: expected a list of facts such as '(on cubeA cubeB)', got {goal!r}")
    if disturb is not None:
        disturb = _check_disturb(disturb)
    robot = robosuite_robot(robot)
    planner = check_planner(planner)
    workers = check_episode_cluster(workers, scheduler)  # before the library is read, and no process starts
    store = open_store(library, create=False)
    try:
        domain = skill_domain(store)
        bindings = {d["label"].lower(): d["binding"] for d in store.descriptions()}
        sources = _sources(store)
    finally:
        if store is not library:
            store.close()
    bindings = {a: check_binding(bindings.get(a), domain.actions[a].parameters, name=f"binding of {a!r}")
                for a in domain.actions}
    arm = running_arm(sources, robot)  # before any episode: a point the arm cannot take is refused
    every = _agreeing([ph for src in sources for ph in _phases(src)])
    phases = [ph for ph in every if ph.label is not None]
    phases += _described(every, phases, domain)
    named = sorted({ph.label for ph in phases if ph.label})
    missing = [a for a in domain.actions if not any(ph.label and ph.label.lower() == a for ph in phases)]
    if missing:
        raise ValueError(f"library: no phase of a demonstration (a reach, or a carry and its release) is "
                         f"labelled {missing}; phases are labelled {named}. Label a primitive of each skill "
                         "(skillbank library label DB --primitive ID NAME)")
    job = _PlanJob(spec=spec, name=name, domain=domain, bindings=bindings, phases=phases, goal=goal,
                   method=method, replan=replan, horizon=horizon, placement=placement, disturb=disturb,
                   search=search, random_state=random_state, paths=paths, robot=robot, planner=planner)
    # each episode builds its own environment from its seed: the same rows here and on any worker
    results, address = run_episodes(_plan_episode, job, [int(seed) + k for k in range(episodes)],
                                    workers=workers, scheduler=scheduler, progress=progress, verbose=verbose)
    rows = [row for row, _ in results]
    timings = {key: sum(t[key] for _, t in results) for key in ("adapt", "driven", "segments", "plan")}
    successes, failures = tally(rows)
    return {"scene": scene, **arm, "method": method, "seed": int(seed), "planner": planner,
            "placement": placement, "episodes": episodes, "successes": successes,
            "success_rate": successes / episodes,
            "interval": list(binomial_interval(successes, episodes)), "failures": failures,
            "timing": {"plan_seconds": timings["plan"], "adapt_seconds": timings["adapt"],
                       "driven_seconds": timings["driven"], "segments": timings["segments"],
                       **transit_timing(t.get("transits", []) for _, t in results)},
            "per_episode": rows, **({} if address is None else {"scheduler": address})}


@dataclass(frozen=True)
class _PlanJob:
    """What every episode of :func:`execute_plan` needs, sent to the workers as it is."""

    spec: Composed
    name: str
    domain: object
    bindings: dict
    phases: list
    goal: object  # the goal's facts, a function of the episode's seed that gives them, or None
    method: str
    replan: bool
    horizon: int
    placement: float | None
    disturb: dict | None
    search: str
    random_state: object
    paths: bool
    robot: str = DRIVEN_ROBOT  # robosuite's arm that carries the plan out
    planner: str = "ompl"  # free-space moves planned for the whole arm (_transit); "none": as adapted


def _plan_episode(job, seed):
    """``(row, timings)`` of one episode of :func:`execute_plan`, in an environment of its own made from
    ``seed``; nothing outlives the call (the environment is closed, the random state is a copy)."""
    suite = import_robosuite()
    if job.spec.env == "Stack3":
        stack3_class()
    environment = _make(suite, job.spec.env, seed, 10 ** 6, job.robot)
    timings = {"adapt": 0.0, "driven": 0.0, "segments": 0, "plan": 0.0}
    goal = job.goal(seed) if callable(job.goal) else job.goal
    try:
        if job.placement is not None:
            _widen(environment, job.placement)
        row = _episode(environment, job.spec, job.name, job.domain, job.bindings, job.phases, seed, goal,
                       job.method, job.replan, job.horizon, job.disturb, job.search, fresh(job.random_state),
                       job.paths, timings, job.planner)
    finally:
        environment.close()
    return row, timings


def _check_disturb(disturb):
    if not isinstance(disturb, dict) or set(disturb) != {"after", "object", "position"}:
        raise ValueError(f"disturb: expected {{'after': K, 'object': NAME, 'position': [x, y, z]}}, got "
                         f"{disturb!r}")
    after = check_positive(disturb["after"], name="disturb.after", integer=True)
    position = np.asarray(disturb["position"], float)
    if position.shape != (3,) or not np.isfinite(position).all():
        raise ValueError(f"disturb.position: expected 3 finite numbers (m), got {disturb['position']!r}")
    return {"after": after, "object": str(disturb["object"]), "position": position}


def _episode(env, spec, name, domain, bindings, phases, seed, goal, method, replan, horizon, disturb, search,
             random_state, paths, timings, planner="none"):
    _reseed(env, seed)
    obs = with_object_poses(env, env.reset())
    world = _World(env, spec, obs)
    atoms = _goal_atoms(spec, world, goal)
    if spec.goal == "tower":
        env.order = _tower(atoms)
    if disturb is not None and disturb["object"] not in world.objects:
        raise ValueError(f"disturb.object: the scene has no object {disturb['object']!r}; it has "
                         f"{world.objects}")
    # each segment also leaves as its demonstration did: a composed scene stands beside what it picks up
    episode = _Episode(env, obs, 10 ** 9, trace=paths, reach=Reach(env))
    episode.rest(world.objects)
    episode.fingers = _fingers(env, episode.obs)
    facts = world.facts(episode.obs)
    row = {"seed": seed, "success": False, "objects": {o: world.pose(episode.obs, o)["position"]
                                                        for o in world.objects},
           "facts": {"start": sorted(_text(a) for a in facts)}, "steps": [], "replans": 0}
    tic = time.perf_counter()
    try:
        plan, _ = _plan(domain, world, facts, atoms, search, name)
    except ValueError as error:
        timings["plan"] += time.perf_counter() - tic
        row["plan"] = []
        row["failure"] = {"step": None, "reason": "no plan", "detail": str(error).splitlines()[0]}
        return row
    timings["plan"] += time.perf_counter() - tic
    row["plan"] = [_text((a, args)) for a, args in plan]
    expected, failure, starts = set(facts), None, []
    queue = list(plan)
    while queue and failure is None and not episode.success:
        queue = _highest_first(domain, expected, queue, atoms, world,
                               room=lambda act, args: _grasp_room(episode, phases, domain.actions[act], args,
                                                                  bindings[act]))
        act, args = queue.pop(0)
        action = domain.actions[act]
        number = len(row["steps"]) + 1
        effects = _effects(action, args)
        step = {"step": number, "action": act, "args": list(args),
                "planned": {"add": [_text(a) for n, a in effects if not n],
                            "delete": [_text(a) for n, a in effects if n]}}
        lacking = _lacking(expected, world.facts(episode.obs), domain.predicates)
        if lacking:
            step.update(ok=False, reason="world changed",
                        detail=f"before this step the plan expects {', '.join(map(_text, lacking))}, which "
                               f"the scene no longer shows")
        else:
            starts.append(episode.steps)
            _run_step(episode, world, step, action, args, effects, bindings[act], phases, method, horizon,
                      random_state, timings, planner)
        row["steps"].append(step)
        if step["ok"]:
            expected = _apply(expected, effects)
            if disturb is not None and disturb["after"] == number:
                world.move(disturb["object"], disturb["position"])
                episode.rest(world.objects)
                step["disturbed"] = {"object": disturb["object"],
                                     "position": [float(v) for v in disturb["position"]]}
            continue
        if replan and row["replans"] < MAX_REPLANS and step["reason"] not in ("no skill", "collision"):
            row["replans"] += 1
            observed = world.facts(episode.obs)
            tic = time.perf_counter()
            try:
                queue, _ = _plan(domain, world, observed, atoms, search, name)
            except ValueError as error:
                failure = {"step": number, "reason": "no plan", "detail": str(error).splitlines()[0]}
            timings["plan"] += time.perf_counter() - tic
            step["replanned"] = [_text(s) for s in queue]
            expected = set(observed)
            continue
        failure = {"step": number, "reason": step["reason"], "detail": step["detail"]}
    for _ in range(SETTLE):  # a last second for the objects to come to rest
        if episode.success:
            break
        episode.act(np.r_[np.zeros(6), episode.driver.grip])
    row["success"] = bool(episode.success)
    row["facts"]["end"] = sorted(_text(a) for a in world.facts(episode.obs))
    row["end_objects"] = {o: world.pose(episode.obs, o)["position"] for o in world.objects}
    row["control_steps"] = episode.steps
    if paths:
        row["path"] = np.round(np.array(episode.path), 6).tolist()
        row["step_starts"] = starts
    if not row["success"]:
        if failure is None:
            lacking = [g for g in atoms if _text(g) not in row["facts"]["end"]]
            shown = f"; the scene does not show {', '.join(map(_text, lacking))}" if lacking else ""
            failure = {"step": None, "reason": "misplaced",
                       "detail": f"the environment's success check fails at the end{shown}"}
        row["failure"] = failure
    return row


def _run_step(episode, world, step, action, args, effects, binding, phases, method, horizon, random_state,
              timings, planner="none"):
    """Carry out one plan step by the nearest phase bound to its arguments; fill ``step``'s facts."""
    chosen = _chosen(episode, phases, action, args, binding)
    if chosen is None:
        step.update(ok=False, reason="no skill", detail=f"no phase labelled {action.name!r} acts on objects "
                                                        f"that can be bound to {list(args)}")
        return
    phase, segments = chosen
    step["source"] = phase.source.id
    step["primitives"] = [seg.primitive.id for seg in segments]
    episode.horizon = episode.steps + horizon
    episode.contact = None  # an arm link's touch, in this step
    if phase.kind == "reach" and method != "replay":
        # a reach was shown from where its demonstration began (the robot's start, clear of the scene):
        # the tool goes back there first, as the demonstrations' robot did, rather than sweep across
        # the scene from where the last step left it
        demo = segments[0].primitive.demo
        try:
            step["transit"] = _transit(episode, np.asarray(demo["position"][0], float),
                                       np.asarray(demo["orientation"][0], float), planner=planner,
                                       random_state=random_state, timings=timings)
        except MotionPlanningError as error:
            step.update(ok=False, reason="no transit", detail=str(error).splitlines()[0])
            return
    misses = []  # the step is judged by its effect, which the world shows, not by where the tool stopped
    failure = _run_segments(episode, segments, phase.source.actions, method, random_state, timings, misses,
                            planner=planner)
    if misses:
        step["notes"] = misses
    timings["segments"] += len(segments)
    if failure is None:
        _let_fingers_settle(episode)
    observed = world.facts(episode.obs)
    shown = {a for a in observed if a[0] in {atom[0] for _, atom in effects}}
    step["observed"] = {"facts": sorted(_text(a) for a in shown),
                        "objects": {o: world.pose(episode.obs, o) for o in args if o in world.objects}}
    if episode.contact is not None:
        step["arm_contact"] = episode.contact[1]

    def fail(reason, detail):
        if episode.contact is not None and reason != "timeout":
            # an arm link touched the scene first: that is what went wrong
            reason, detail = "collision", f"{episode.contact[1]}; then {reason}: {detail}"
        step.update(ok=False, reason=reason, detail=detail)

    if failure is not None and not episode.success:
        i, reason, detail = failure
        fail(reason, f"segment {i} (primitive {segments[i].primitive.id}): {detail}")
        return
    wrong = [(n, a) for n, a in effects if a[0] in OBSERVED and (a in observed) == n]
    if wrong and not episode.success:
        neg, atom = wrong[0]
        held = atom[0] == "holding"
        reason = "not held" if held and not neg else "misplaced"
        where = step["observed"]["objects"].get(atom[1][0] if atom[1] else None)
        landed = "" if where is None else f"; {atom[1][0]} is at {where['position']} m" + \
            (" in the gripper" if where["held"] else "")
        fail(reason, f"the plan expects {'not ' if neg else ''}{_text(atom)}, the scene does not show "
                     f"it{landed}")
        return
    step["ok"] = True


def _chosen(episode, phases, action, args, binding):
    """``(phase, segments)`` that carry out ``action`` on ``args`` from here: of the phases bound to the
    arguments, the least adapted among those whose goals the arm reaches; None if no phase is bound."""
    options = _candidates(phases, action, args, binding)
    if not options:
        return None
    bound = [(ph, [replace(seg, names=names) for seg in ph.segments]) for ph, names in options]
    return min(bound, key=lambda b: (_beyond(episode, b[1]), _cost(b[1], episode.obs, episode.fingers)))


def _grasp_room(episode, phases, action, args, binding) -> float:
    """How far (m) the fingertips come from the nearest other object where the step's phase closes the
    gripper on its object (infinite for a step that grasps nothing or has no phase)."""
    chosen = _chosen(episode, phases, action, args, binding)
    room = np.inf
    for seg in [] if chosen is None else chosen[1]:
        grip = seg.primitive.demo["actions"][:, 6]
        if grip[0] <= 0 < grip[-1]:  # the fingers close on what it reaches
            p, q = _goal(seg, episode.obs, episode.fingers)
            room = min(room, _room(p, q, episode.fingers, _others(seg, episode.obs)))
    return room


def _beyond(episode, segments) -> int:
    """How many of the segments' goals lie beyond the arm's reach margin from where it is now.

    The demonstrations of a step let go of an object at spots a few centimetres apart (each a spot the
    task accepts); at the edge of the workspace, one of them can need a straight elbow where another
    does not. A step is carried out by the least adapted phase among those whose goals the arm reaches
    with its elbow bent.
    """
    if episode.reach is None:
        return 0
    goals = [_goal(seg, episode.obs, episode.fingers) for seg in segments]
    P = np.array([p for p, _ in goals])
    Q = np.array([episode.obs["robot0_eef_quat"] if q is None else q for _, q in goals], float)
    return int((~episode.reach.reaches(P, Q, episode.obs["robot0_joint_pos"])).sum())


def _transit(episode, position, quat, *, planner="none", random_state=None, timings=None) -> float:
    """Move the tool to ``position``, ``quat`` if it is farther than :data:`TRANSIT_FROM`; returns the
    distance moved.

    With ``planner="ompl"`` the move is planned for the whole arm in joint space
    (:func:`~skillbank.simulation._transit.move_to`: every link and the gripper clear of the scene's
    MuJoCo geoms; its planning seconds appended to ``timings["transits"]``). With ``planner="none"`` it is
    the rule kept for comparison: up by :data:`TRANSIT_RISE` above the higher of the two ends, across,
    and down, each a straight minimum-jerk line at most :data:`TRANSIT_SPEED`, within the arm's reach
    margin (:class:`~skillbank.simulation._reach.Reach`).
    """
    here_p = np.array(episode.obs["robot0_eef_pos"], float)
    here_q = np.array(episode.obs["robot0_eef_quat"], float)
    distance = float(np.linalg.norm(position - here_p))
    if distance <= TRANSIT_FROM:
        return 0.0
    if planner == "ompl":
        P, Q, seconds, J = move_to(episode.env, episode.obs, position, quat, random_state=random_state)
        if timings is not None:
            timings.setdefault("transits", []).append(round(seconds, 4))
    else:
        P, Q = _up_across_down(episode, here_p, here_q, np.asarray(position, float), quat)
        J = [None] * len(P)
    for p, q, joints in zip(P, Q, J, strict=True):
        if episode.over:
            return round(distance, 4)
        episode.step(p, q, posture=joints)
    episode.settle(P[-1], quat)
    return round(distance, 4)


def _up_across_down(episode, here_p, here_q, position, quat):
    """The rule a transit follows without a planner: rising first takes the arm out of what it has just
    reached into (a bin's far corner: its forearm lies over the bin's wall) before it swings back."""
    z = max(here_p[2], position[2]) + TRANSIT_RISE
    corners = [here_p, np.r_[here_p[:2], z], np.r_[position[:2], z], position]
    turns = [here_q, here_q, quat, quat]
    P, Q = [], []
    for a, b, qa, qb in zip(corners[:-1], corners[1:], turns[:-1], turns[1:], strict=True):
        length = float(np.linalg.norm(b - a))
        # a minimum-jerk profile peaks at 1.875 times its mean speed
        n = max(CONTROL_FREQ // 2, int(np.ceil(1.875 * length / TRANSIT_SPEED * CONTROL_FREQ)))
        u = _min_jerk_at(np.linspace(0.0, 1.0, n + 1)[1:])
        P.append(a + u[:, None] * (b - a))
        Q.append(slerp([0.0, 1.0], np.stack([qa, qb]), u))
    P, Q = np.concatenate(P), np.concatenate(Q)
    # rising straight up from a bin's far side stretches the arm: the path keeps its reach margin
    if episode.reach is not None:
        P = episode.reach.keep(P, Q, episode.obs["robot0_joint_pos"])
    return P, Q


def _let_fingers_settle(episode, *, most=CONTROL_FREQ, still=1e-4) -> None:
    """Hold the tool where it is until the fingers stop moving (at most ``most`` steps): a step that ends
    by closing the gripper holds the object once the fingers have closed, not when the command was given."""
    fingers = np.array(episode.obs["robot0_gripper_qpos"], float)
    here_p = np.array(episode.obs["robot0_eef_pos"], float)
    here_q = np.array(episode.obs["robot0_eef_quat"], float)
    for _ in range(most):
        if episode.over:
            break
        episode.step(here_p, here_q)
        now = np.array(episode.obs["robot0_gripper_qpos"], float)
        if np.abs(now - fingers).max() < still:
            break
        fingers = now

