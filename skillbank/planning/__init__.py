"""Task planning over labelled skills: compose a task that was never demonstrated.

A labelled skill can carry a *description*: a PDDL action schema (parameters
with types, precondition, effect) and a *binding* (which argument's pose is
the step's goal, an offset, the orientation, the obstacles that apply, the
gripper at the start and end). Given a :class:`Scene` (objects with poses,
obstacles, initial facts, a goal, a start), :func:`plan_task` writes the PDDL
domain and problem, finds a plan (skillbank's greedy best-first search with
the FF heuristic by default; the shortest with A* and LM-cut in jupyddl, the
``plan`` extra, on request) and reproduces it as one executable trajectory:
each step a :func:`skillbank.selection.reuse` of its skill starting exactly
where the previous one ended (:func:`reproduce_plan`).

Examples
--------
>>> from skillbank.planning import parse_action, check_binding
>>> a = parse_action("(:action press :parameters (?b - button) :precondition (free ?b) "
...                  ":effect (and (pressed ?b) (not (free ?b))))")
>>> check_binding({"offset": [0, 0, 0.002]}, a.parameters).offset.tolist()
[0.0, 0.0, 0.002]
"""

from ._binding import BINDING_KEYS, DEFAULT_METHOD, Binding, check_binding
from ._chain import CLEARANCE, EMPTY_PLAN, PlanResult, PlanStep, arm_clearance, reproduce_plan
from ._pddl import Action, Domain, domain_text, parse_action, parse_atom, parse_domain, problem_text
from ._plan import describe_skill, plan_task, skill_domain, write_pddl
from ._scene import Scene, SceneObject, load_scene, scene_from_dict
from ._solve import (
    INSTALL,
    MAX_GROUNDINGS,
    MAX_REACHABLE_GROUNDINGS,
    SEARCHES,
    TIME_LIMIT,
    check_groundings,
    solve,
    solve_with_info,
)

__all__ = [
    "Scene", "SceneObject", "load_scene", "scene_from_dict", "Action", "Domain", "parse_action",
    "parse_domain", "parse_atom", "domain_text", "problem_text", "Binding", "check_binding", "BINDING_KEYS",
    "DEFAULT_METHOD",
    "solve", "solve_with_info", "SEARCHES", "INSTALL", "PlanResult", "PlanStep", "reproduce_plan",
    "describe_skill", "skill_domain",
    "plan_task", "write_pddl", "EMPTY_PLAN", "MAX_GROUNDINGS", "MAX_REACHABLE_GROUNDINGS", "TIME_LIMIT",
    "check_groundings",
    "CLEARANCE", "arm_clearance",
]
