"""Planning over labelled skills: describe a skill, write the domain and problem, solve, reproduce."""

from __future__ import annotations

import os
from pathlib import Path

from ..io import atomic_output
from ..store import Store
from ._binding import check_binding
from ._chain import PlanResult, _Skill, reproduce_plan
from ._json import describe, read_bounded, utf8
from ._pddl import Domain, domain_text, parse_action, parse_domain, problem_text
from ._scene import Scene, load_scene, scene_from_dict
from ._solve import (
    MAX_EXPANSIONS,
    MAX_GROUNDINGS,
    MAX_REACHABLE_GROUNDINGS,
    TIME_LIMIT,
    check_groundings,
    solve,
    unused_types,
)

__all__ = ["describe_skill", "skill_domain", "plan_task", "write_pddl", "MAX_DOMAIN_BYTES"]

#: Largest domain file read (a domain of a thousand actions is far smaller).
MAX_DOMAIN_BYTES = 16 * 2 ** 20


def describe_skill(store: Store, label: str, action, binding=None) -> int:
    """Check and store the description of skill ``label``: a PDDL action schema and its binding.

    The action's name must be the label (an action is carried out by the
    skill of its name); ``binding`` is checked against its parameters
    (:func:`~skillbank.planning.check_binding`). ``action=None`` removes the
    description. Returns the new revision number (the label's first is 1).

    Examples
    --------
    >>> import os, tempfile
    >>> from skillbank.store import open_store
    >>> with open_store(os.path.join(tempfile.mkdtemp(), "lib.db")) as store:
    ...     describe_skill(store, "press", "(:action press :parameters (?b - button) :effect (pressed ?b))",
    ...                    {"offset": [0, 0, 0.01]})
    1
    """
    if not isinstance(label, str) or not label.strip():
        raise ValueError(f"label: expected a non-empty string, got {label!r}")
    if action is None:
        return store.set_description(label, None, {})
    schema = parse_action(action)
    if schema.name != label.lower():
        raise ValueError(f"action: expected an action named after the skill, {label.lower()!r}, got "
                         f"{schema.name!r} (an action is carried out by the skill whose label is its name)")
    checked = check_binding(binding, schema.parameters)
    return store.set_description(label, schema.text, checked.as_dict())


def skill_domain(store: Store, scene: Scene | None = None) -> Domain:
    """The domain of the skills' stored descriptions (types of the scene's objects included)."""
    rows = store.descriptions()
    if not rows:
        raise ValueError("domain: the library has no skill descriptions; attach one with 'skillbank library "
                         "describe DB LABEL --action FILE.pddl' (Library.describe), or give a domain file")
    actions = [parse_action(d["action"], f"description of {d['label']!r}") for d in rows]
    types = () if scene is None else [o.type for o in scene.objects.values()]
    return domain_text(actions, types=types)


def _labels(store: Store) -> list:
    return sorted({p.label for p in store.primitives(load=False) if p.label is not None})


def _skills(store: Store, domain: Domain):
    """``lookup(action, where) -> _Skill``: the label named like the action, its binding and primitives."""
    stored = {d["label"].lower(): d for d in store.descriptions()}
    labels = _labels(store)
    cache = {}

    def lookup(action, where):
        if action in cache:
            return cache[action]
        same = [lab for lab in labels if lab == action] or [lab for lab in labels if lab.lower() == action]
        if len(same) > 1:
            raise ValueError(f"{where}: labels {same} all name action {action!r}; keep one")
        if not same:
            raise ValueError(f"{where}: skill {action!r} has no usable primitive: no primitive is labelled "
                             f"{action!r} (labels in the library: {labels})")
        params = domain.actions[action].parameters if action in domain.actions else []
        doc = stored.get(action, {}).get("binding")
        binding = check_binding(doc, params, name=f"binding of {same[0]!r}")
        cache[action] = _Skill(same[0], params, binding, store.primitives(label=same[0]))
        return cache[action]

    return lookup


def _check_scene_against(domain: Domain, scene: Scene) -> None:
    for key in ("init", "goal"):
        for k, (pred, args) in enumerate(getattr(scene, key)):
            if pred in domain.predicates and len(domain.predicates[pred]) != len(args):
                raise ValueError(f"{key}[{k}]: predicate {pred!r} takes {len(domain.predicates[pred])} "
                                 f"argument(s) in the domain, got {len(args)}")
            if key == "init" and pred not in domain.predicates:
                raise ValueError(f"init[{k}]: predicate {pred!r} is in no action of the domain (predicates "
                                 f"{sorted(domain.predicates)})")


def _domain(store, scene, domain) -> Domain:
    if domain is None and scene.domain is not None:
        domain = scene.domain
    if domain is None:
        return skill_domain(store, scene)
    if isinstance(domain, Domain):
        return domain
    if isinstance(domain, os.PathLike) or (isinstance(domain, str) and not domain.lstrip().startswith("(")):
        return parse_domain(_read_domain(Path(domain)), f"domain {Path(domain).name}")
    return parse_domain(domain)


def _read_domain(path: Path) -> str:
    """The text of a domain file: at most MAX_DOMAIN_BYTES of UTF-8."""
    data = read_bounded(path, "domain", MAX_DOMAIN_BYTES, kind="a PDDL domain file")
    return utf8(data, f"domain {str(path)!r}")


def _scene(scene) -> Scene:
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, dict):
        return scene_from_dict(scene)
    if isinstance(scene, (str, os.PathLike)):
        return load_scene(scene)
    raise ValueError(f"scene: expected a Scene, a dict (a scene's content, as in a scene file) or the path "
                     f"of a scene file, got {describe(scene)}")


def plan_task(store: Store, scene, *, domain=None, robot=None, limits=None, random_state=None,
              max_expansions: int = MAX_EXPANSIONS, max_groundings: int | None = None,
              time_limit: float = TIME_LIMIT, progress=None, clearance=None,
              search: str = "satisficing", planner: str = "ompl", motion_time_limit=None) -> PlanResult:
    """Plan a task over the library's labelled skills in a scene, and reproduce the plan as one trajectory.

    1. The domain: ``domain`` (a :class:`Domain`, PDDL text or a file; used as
       it is), else the scene's ``domain`` file, else the skills' stored
       descriptions; the problem from the scene's objects, ``init`` and ``goal``.
    2. A plan, by :func:`~skillbank.planning.solve` (``search``: satisficing
       by default, the shortest with ``"optimal"``).
    3. Each step reproduced by its skill (the label named like the action)
       and chained (:func:`~skillbank.planning.reproduce_plan`).

    Parameters
    ----------
    store : Store
    scene : Scene, dict, str or path
        A :class:`Scene`, a dict with a scene file's content (without
        ``domain``, which names a file beside a scene file), or a scene file.
    domain : Domain, str or path, optional
    robot : str or RobotModel, optional
        ``"ur5e"``: one continuous joint trajectory.
    limits : dict, optional
        Velocity and acceleration limits (see :func:`skillbank.selection.reuse`).
    random_state : int, optional
    max_expansions : int
        States the planner may expand before giving up.
    max_groundings : int, optional
        Ground actions the planner may build: by default
        :data:`~skillbank.planning.MAX_GROUNDINGS` type-consistent ones for the
        optimal search (checked before it starts), and
        :data:`~skillbank.planning.MAX_REACHABLE_GROUNDINGS` reachable ones for
        the satisficing search (counted as it grounds).
    time_limit : float
        Seconds the planner may search before giving up.
    progress : callable, optional
        ``progress(done, total)`` over the steps reproduced.
    clearance : float, optional
        With a robot: metres every body of the robot keeps from the obstacles, the table, the workspace
        bounds and itself (default :data:`~skillbank.planning.CLEARANCE`, 5 mm beyond its capsules).
    search : {"satisficing", "optimal"}
        The planner's search (see :data:`~skillbank.planning.SEARCHES`): greedy best-first with h_ff,
        which scales to hundreds of objects, or A* with LM-cut (jupyddl), the fewest steps.
    planner : {"ompl", "none"}, default="ompl"
        With a robot: a step whose skill (and hand-written transit) cannot keep the robot clear has its
        move planned in joint space by OMPL (the ``plan`` extra; docs/planning.md, "Planned transits");
        ``"none"`` refuses such a step.
    motion_time_limit : float, optional
        Seconds the motion planner may search per transit (default
        :data:`skillbank.robots.MOTION_TIME_LIMIT`).

    Returns
    -------
    PlanResult

    Raises
    ------
    ValueError
        One line: a bad scene (naming the key), a goal no plan reaches (naming
        the facts), a step whose skill has no usable primitive (naming the
        step and the reasons), a step that cannot avoid an obstacle (naming
        the step and the obstacle).
    """
    scene = _scene(scene)
    dom = _domain(store, scene, domain)
    _check_scene_against(dom, scene)
    objects = {name: obj.type for name, obj in scene.objects.items()}
    problem = problem_text(objects, scene.init, scene.goal, domain=dom.name)
    if max_groundings is None:
        max_groundings = MAX_GROUNDINGS if search == "optimal" else MAX_REACHABLE_GROUNDINGS
    if search == "optimal":  # jupyddl builds every type-consistent ground action before it searches
        check_groundings(dom, objects, max_groundings=max_groundings)
    try:
        steps = solve(dom.text, problem, search=search, max_expansions=max_expansions, time_limit=time_limit,
                      max_groundings=max_groundings)
    except ValueError as exc:
        if str(exc).startswith("domain: expected at most max_groundings"):
            # more are reachable than the bound: the count over the scene's objects says by how much
            check_groundings(dom, objects, max_groundings=max_groundings)
        unused = unused_types(dom, objects)  # a scene of switches planned with a 'press ?b - button' action
        if not unused or not str(exc).startswith(("goal:", "planner:")):
            raise
        raise ValueError(f"{exc}{unused}") from None
    result = reproduce_plan(scene, steps, _skills(store, dom), robot=robot, limits=limits,
                            clearance_margin=clearance, planner=planner, motion_time_limit=motion_time_limit,
                            random_state=random_state, progress=progress)
    result.domain, result.problem = dom.text, problem
    return result


def write_pddl(result: PlanResult, stem) -> tuple:
    """Write ``<stem>.domain.pddl`` and ``<stem>.problem.pddl``; returns both paths.

    Examples
    --------
    >>> import os, tempfile
    >>> res = PlanResult([], [], None, False, 0.0, {}, domain="(define (domain d))", problem="(define)")
    >>> [p.name for p in write_pddl(res, os.path.join(tempfile.mkdtemp(), "plan"))]
    ['plan.domain.pddl', 'plan.problem.pddl']
    """
    stem = Path(stem)
    paths = (stem.with_name(stem.name + ".domain.pddl"), stem.with_name(stem.name + ".problem.pddl"))
    for path, text in zip(paths, (result.domain, result.problem), strict=True):
        with atomic_output(path, name="plot") as tmp:  # whole; a link there is replaced, not written through
            tmp.write_text(text)
    return paths
