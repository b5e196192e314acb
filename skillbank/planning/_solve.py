"""Solving a PDDL problem in-process, and saying why when no plan exists.

Two searches (:data:`SEARCHES`):

- ``"satisficing"`` (the default): skillbank's own grounding by relaxed
  reachability and greedy best-first search with the FF heuristic
  (:mod:`skillbank.planning._search`, pure Python and numpy). It scales to
  hundreds of objects; its plans are short but not guaranteed shortest.
- ``"optimal"``: A* with the LM-cut heuristic in jupyddl (the ``plan``
  extra), which is admissible: the plan found has the fewest actions. Its
  grounding (about 0.2 ms per ground action) and the states it expands
  (2^N - 1 on a task of reaching N places in any order) limit it to small tasks.

Before searching, a relaxed reachability analysis (deletes ignored) names the
goal facts that no sequence of actions can make true; a problem whose facts
are each reachable but not together is reported as such.
"""

from __future__ import annotations

import re
import tempfile
import time
from collections import Counter
from pathlib import Path

from ..core._defaults import TIME_LIMIT  # defined where Library takes it as a default, importing no planner
from ..core._validation import check_positive, summarise
from . import _search
from ._pddl import Domain, _typed_list, parse_sexpr

__all__ = ["solve", "solve_with_info", "SEARCHES", "planner", "MAX_EXPANSIONS", "MAX_GROUNDINGS",
           "MAX_REACHABLE_GROUNDINGS", "TIME_LIMIT", "INSTALL", "check_groundings", "unused_types"]

#: States the search expands before it gives up (a 10-step button task expands under a hundred).
MAX_EXPANSIONS = 200_000
#: Ground actions (an action with its parameters bound to objects of their types) the planner may build.
#: It grounds every one before it searches, at about 0.2 ms each (10^5 took 20 s): an action of 6
#: parameters in a scene of 20 objects has 6.4e7 and would run for hours. A button task has one per button.
MAX_GROUNDINGS = 100_000
#: ... and the reachable ground actions skillbank's own satisficing search may build (it builds only
#: those relaxed reachability allows, at about 20 µs and 1.4 kB each: 103041 in 2.1 s and 146 MB), so
#: at most about 5 s and 350 MB of grounding.
MAX_REACHABLE_GROUNDINGS = 250_000
_CAP = 10 ** 18
INSTALL = "pip install 'skillbank[plan]'"
#: The searches :func:`solve` offers, by name, and the planner that runs each.
SEARCHES = {"satisficing": "GBFS with h_ff (skillbank)", "optimal": "A* with LM-cut (jupyddl)"}
_STEP = re.compile(r"^\s*([^\s(]+)\s*\((.*)\)\s*$")


def planner():
    """The jupyddl module, or an ImportError saying what to install."""
    try:
        import jupyddl  # optional extra 'plan': imported when a plan is solved
    except ImportError:
        raise ImportError(f"planning needs the PDDL planner jupyddl: {INSTALL}") from None
    return jupyddl


def _unreachable(task) -> list:
    """Goal facts no sequence of actions reaches when deletes are ignored (so none reaches them).

    Each operator waits on a count of its preconditions not yet reached, and
    each fact is reached once: linear in the size of the task.
    """
    reached = set(task.init)
    waiting, needs = {}, {}
    frontier = []
    for op in task.operators:
        missing = op.precond - reached
        waiting[id(op)] = len(missing)
        for fact in missing:
            needs.setdefault(fact, []).append(op)
        if not missing:
            frontier.append(op)
    while frontier:
        op = frontier.pop()
        for fact in op.add - reached:
            reached.add(fact)
            for other in needs.get(fact, ()):
                waiting[id(other)] -= 1
                if waiting[id(other)] == 0:
                    frontier.append(other)
    return sorted(task.fact_name(f) for f in task.goals - reached)


def _parents(domain: Domain) -> dict:
    """Type -> its parent type, from the domain's ``(:types a b - c ...)``."""
    expr = parse_sexpr(domain.text, "domain") if domain.text else []
    for part in expr[2:] if isinstance(expr, list) else []:
        if isinstance(part, list) and part[:1] == [":types"]:
            return dict(_typed_list(part[1:], "domain :types", variables=False))
    return {}


def _fits(domain: Domain):
    """``fits(kind, wanted)``: whether an object of type ``kind`` can bind a parameter of type ``wanted``
    (its type or an ancestor; every type fits ``object``)."""
    parents = _parents(domain)

    def fits(kind: str, wanted: str) -> bool:
        seen = set()
        while kind not in seen:  # up the hierarchy (a cycle in a bad domain ends the walk)
            if kind == wanted:
                return True
            seen.add(kind)
            kind = parents.get(kind, "object")
        return wanted == "object"

    return fits


def unused_types(domain: Domain, objects: dict) -> str:
    """A clause naming the scene's types that no action's parameter takes (``""`` when every type is used).

    Examples
    --------
    >>> from skillbank.planning import domain_text, parse_action
    >>> d = domain_text([parse_action("(:action press :parameters (?b - button) :effect (pressed ?b))")])
    >>> print(unused_types(d, {"b1": "button", "s1": "switch", "s2": "switch"})[:60])
    ; type 'switch' of the scene's objects s1, s2 is the type of
    """
    fits = _fits(domain)
    wanted = sorted({t for a in domain.actions.values() for _, t in a.parameters})
    unused: dict = {}
    for name, kind in objects.items():
        if not any(fits(kind, w) for w in wanted):
            unused.setdefault(kind, []).append(name)
    if not unused:
        return ""
    shown = "; ".join(f"type {k!r} of the scene's objects {summarise(v)}" for k, v in sorted(unused.items()))
    verb = "is" if len(unused) == 1 else "are each"
    return f"; {shown} {verb} the type of no action's parameter (the actions take {', '.join(wanted)})"


def check_groundings(domain: Domain, objects: dict, *, max_groundings: int = MAX_GROUNDINGS) -> int:
    """The number of ground actions of ``domain`` over ``objects`` (name -> type); ValueError above the bound.

    An object fits a parameter whose type is its type or an ancestor of it
    (every object fits ``object``). Counted before the planner grounds them.

    Examples
    --------
    >>> from skillbank.planning import domain_text, parse_action
    >>> d = domain_text([parse_action("(:action move :parameters (?a ?b - place) :effect (at ?b))")])
    >>> check_groundings(d, {"p1": "place", "p2": "place", "b1": "button"})
    4
    """
    max_groundings = check_positive(max_groundings, name="max_groundings", integer=True)
    fits = _fits(domain)
    kinds = Counter(objects.values())
    fitting = {}
    counts = {}
    for name, action in domain.actions.items():
        count = 1
        for _, wanted in action.parameters:
            if wanted not in fitting:
                fitting[wanted] = sum(n for kind, n in kinds.items() if fits(kind, wanted))
            count = min(count * fitting[wanted], _CAP)  # capped: a message never shows a 1000-digit count
        counts[name] = count
    total = min(sum(counts.values()), _CAP)
    if total > max_groundings:
        worst = max(counts, key=counts.get)

        def shown(n):
            return f"over {_CAP:.0e}" if n >= _CAP else str(n)

        raise ValueError(f"domain: expected at most max_groundings={max_groundings} ground actions (the "
                         f"planner builds each before it searches), got {shown(total)} in this scene (action "
                         f"{worst}: {len(domain.actions[worst].parameters)} parameter(s) over {len(objects)} "
                         f"object(s), {shown(counts[worst])}); give fewer objects or parameters, or raise "
                         "the bound (--max-groundings, plan(max_groundings=...))")
    return total


def _step(name: str) -> tuple:
    m = _STEP.match(name)
    if m is None:
        raise ValueError(f"planner: expected steps written 'action(arg, ...)', got {name!r}")
    args = tuple(a.strip().lower() for a in m.group(2).split(",") if a.strip())
    return m.group(1).lower(), args


def solve(domain: str, problem: str, *, search: str = "satisficing", max_expansions: int = MAX_EXPANSIONS,
          time_limit: float = TIME_LIMIT, max_groundings: int | None = None) -> list:
    """A plan ``[(action, (args...))]`` of a domain and problem (PDDL text); the shortest with ``"optimal"``.

    Parameters
    ----------
    domain, problem : str
        PDDL text (STRIPS with typing and negative preconditions).
    search : {"satisficing", "optimal"}
        ``"satisficing"``: skillbank's greedy best-first search with the FF
        heuristic, which scales to hundreds of objects (no extra needed);
        ``"optimal"``: A* with LM-cut in jupyddl, the fewest actions (needs
        the ``plan`` extra). See :data:`SEARCHES`.
    max_expansions : int
        States the search may expand before it gives up.
    time_limit : float
        Seconds the planner may run before it gives up (the satisficing
        search counts its grounding too).
    max_groundings : int, optional
        Ground actions the satisficing search may build, counted as it grounds
        only what relaxed reachability allows (default
        :data:`MAX_REACHABLE_GROUNDINGS`; the optimal
        search grounds everything: :func:`check_groundings` bounds it before it
        starts, as :func:`~skillbank.planning.plan_task` does).

    Raises
    ------
    ValueError
        ``"goal: no plan reaches (pressed b4): ..."`` naming the facts that no
        action can make true; or that the facts cannot all hold together; or
        that the search gave up after ``max_expansions`` states or
        ``time_limit`` seconds.
    ImportError
        With ``search="optimal"`` and without the planner, naming ``pip install 'skillbank[plan]'``.

    Examples
    --------
    >>> d = ("(define (domain d) (:requirements :strips :typing) (:types button) "
    ...      "(:predicates (pressed ?b - button)) "
    ...      "(:action press :parameters (?b - button) :effect (pressed ?b)))")
    >>> p = "(define (problem p) (:domain d) (:objects b1 b2 - button) (:init) (:goal (and (pressed b2))))"
    >>> solve(d, p)
    [('press', ('b2',))]
    """
    return solve_with_info(domain, problem, search=search, max_expansions=max_expansions,
                           time_limit=time_limit, max_groundings=max_groundings)[0]


def solve_with_info(domain: str, problem: str, *, search: str = "satisficing",
                    max_expansions: int = MAX_EXPANSIONS, time_limit: float = TIME_LIMIT,
                    max_groundings: int | None = None) -> tuple:
    """``(steps, info)``: :func:`solve`'s plan and how it was found.

    ``info`` holds ``search`` (the name asked for), ``planner`` (its entry
    in :data:`SEARCHES`), ``expanded`` (states the search expanded) and
    ``seconds`` (grounding and search).

    Examples
    --------
    >>> d = ("(define (domain d) (:requirements :strips :typing) (:types button) "
    ...      "(:action press :parameters (?b - button) :effect (pressed ?b)))")
    >>> p = "(define (problem p) (:domain d) (:objects b1 b2 - button) (:init) (:goal (and (pressed b2))))"
    >>> steps, info = solve_with_info(d, p)
    >>> steps, info["planner"], info["expanded"]
    ([('press', ('b2',))], 'GBFS with h_ff (skillbank)', 1)
    """
    if search not in SEARCHES:
        raise ValueError(f"search: expected one of {', '.join(map(repr, SEARCHES))}, got {search!r}")
    max_expansions = check_positive(max_expansions, name="max_expansions", integer=True)
    time_limit = check_positive(time_limit, name="time_limit")
    if max_groundings is not None:
        max_groundings = check_positive(max_groundings, name="max_groundings", integer=True)
    elif search != "optimal":
        max_groundings = MAX_REACHABLE_GROUNDINGS
    start = time.perf_counter()
    if search == "optimal":
        steps, expanded = _optimal(domain, problem, max_expansions=max_expansions, time_limit=time_limit)
    else:
        steps, expanded = _satisficing(domain, problem, max_expansions=max_expansions, time_limit=time_limit,
                                       max_groundings=max_groundings)
    info = {"search": search, "planner": SEARCHES[search], "expanded": expanded,
            "seconds": time.perf_counter() - start}
    return steps, info


def _unreachable_error(missing) -> ValueError:
    return ValueError(f"goal: no plan reaches {summarise(missing)}: no sequence of the skills' actions "
                      f"makes {'it' if len(missing) == 1 else 'them'} true from the initial facts")


def _gave_up(reason: str, expanded: int, *, max_expansions: int, time_limit: float) -> ValueError:
    if reason == "expansions":
        return ValueError(f"goal: the planner gave up after {max_expansions} states without a plan "
                          "(max_expansions)")
    return ValueError(f"goal: the planner gave up after {time_limit:g} s without a plan ({expanded} "
                      "states); raise the bound if the task is meant (--time-limit, plan(time_limit=...))")


def _together_error(goals) -> ValueError:
    return ValueError(f"goal: no plan reaches {summarise(goals)} together: each fact is reachable, but no "
                      "sequence of the skills' actions makes them true at once")


def _satisficing(domain: str, problem: str, *, max_expansions: int, time_limit: float,
                 max_groundings: int | None = None) -> tuple:
    """skillbank's grounding and GBFS with h_ff, then action elimination: ``(steps, states expanded)``."""
    deadline = time.perf_counter() + time_limit
    try:
        task = _search.ground(domain, problem, deadline=deadline, max_groundings=max_groundings)
        if task.unreachable:
            raise _unreachable_error(task.unreachable)
        plan, expanded = _search.search(task, max_expansions=max_expansions, deadline=deadline)
    except _search.SearchFailed as failed:
        if failed.reason == "exhausted":
            raise _together_error(sorted(task.facts[g] for g in task.goal)) from None
        if failed.reason == "groundings":
            raise ValueError(f"domain: expected at most max_groundings={max_groundings} ground actions "
                             f"reachable from the initial facts, got more; give fewer objects or parameters, "
                             "or raise the bound (--max-groundings, plan(max_groundings=...))") from None
        raise _gave_up(failed.reason, failed.expanded, max_expansions=max_expansions,
                       time_limit=time_limit) from None
    # the greedy search can wander; dropping the actions the goal does not need is cheap (quadratic in
    # the plan's length, no search)
    plan = _search.eliminate(task, plan)
    return [task.names[op] for op in plan], expanded


def _optimal(domain: str, problem: str, *, max_expansions: int, time_limit: float) -> tuple:
    """jupyddl's grounding and A* with LM-cut: ``(steps, states expanded)``."""
    jp = planner()
    with tempfile.TemporaryDirectory(prefix="skillbank-plan-") as tmp:
        # jupyddl reads files: the same text the user can inspect beside the plot
        (Path(tmp) / "domain.pddl").write_text(domain)
        (Path(tmp) / "problem.pddl").write_text(problem)
        try:
            task = jp.build_task(str(Path(tmp) / "domain.pddl"), str(Path(tmp) / "problem.pddl"))
        except (jp.PDDLError, ValueError, IndexError, KeyError, TypeError, RecursionError) as exc:
            # the planner's own reader, on PDDL skillbank's reader let through: one line, not its traceback
            detail = " ".join(str(exc).split())[:200] or type(exc).__name__
            raise ValueError(f"planner: the PDDL was refused: {detail}") from None
    missing = _unreachable(task)
    if missing:
        raise _unreachable_error(missing)
    try:
        result = jp.solve_task(task, "astar", "lmcut", max_expansions=max_expansions, time_limit=time_limit)
    except (ValueError, IndexError, KeyError, TypeError, RecursionError) as exc:  # the planner's, not ours
        detail = " ".join(str(exc).split())[:200] or type(exc).__name__
        raise ValueError(f"planner: the search failed on this task ({type(exc).__name__}: {detail})") \
            from None
    if not result.solved:
        if result.stats.truncated and result.stats.expanded >= max_expansions:
            raise _gave_up("expansions", result.stats.expanded, max_expansions=max_expansions,
                           time_limit=time_limit)
        if result.stats.truncated:
            raise _gave_up("time", result.stats.expanded, max_expansions=max_expansions,
                           time_limit=time_limit)
        raise _together_error(sorted(task.fact_name(f) for f in task.goals))
    return [_step(op.name) for op in result.plan], result.stats.expanded
