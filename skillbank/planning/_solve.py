"""Solving a PDDL problem in-process with jupyddl (the ``plan`` extra), and saying why when none exists.

The search is A* with the LM-cut heuristic, which is admissible: the plan
found has the fewest actions. Before searching, a relaxed reachability
analysis (deletes ignored) names the goal facts that no sequence of actions
can make true; a problem whose facts are each reachable but not together is
reported as such.
"""

from __future__ import annotations

import re
import tempfile
from pathlib import Path

from ..core._validation import summarise

__all__ = ["solve", "planner", "MAX_EXPANSIONS", "INSTALL"]

#: States the search expands before it gives up (a 10-step button task expands under a hundred).
MAX_EXPANSIONS = 200_000
INSTALL = "pip install 'skillbank[plan]'"
_STEP = re.compile(r"^\s*([^\s(]+)\s*\((.*)\)\s*$")


def planner():
    """The jupyddl module, or an ImportError saying what to install."""
    try:
        import jupyddl  # optional extra 'plan': imported when a plan is solved
    except ImportError:
        raise ImportError(f"planning needs the PDDL planner jupyddl: {INSTALL}") from None
    return jupyddl


def _unreachable(task) -> list:
    """Goal facts no sequence of actions reaches when deletes are ignored (so none reaches them)."""
    reached = set(task.init)
    ops = list(task.operators)
    grew = True
    while grew:
        grew = False
        rest = []
        for op in ops:
            if op.precond <= reached:
                new = op.add - reached
                if new:
                    reached |= new
                    grew = True
            else:
                rest.append(op)
        ops = rest
    return sorted(task.fact_name(f) for f in task.goals - reached)


def _step(name: str) -> tuple:
    m = _STEP.match(name)
    if m is None:
        raise ValueError(f"planner: expected steps written 'action(arg, ...)', got {name!r}")
    args = tuple(a.strip().lower() for a in m.group(2).split(",") if a.strip())
    return m.group(1).lower(), args


def solve(domain: str, problem: str, *, max_expansions: int = MAX_EXPANSIONS) -> list:
    """The shortest plan ``[(action, (args...))]`` of a domain and problem (PDDL text).

    Raises
    ------
    ValueError
        ``"goal: no plan reaches (pressed b4): ..."`` naming the facts that no
        action can make true; or that the facts cannot all hold together; or
        that the search gave up after ``max_expansions`` states.
    ImportError
        Without the planner, naming ``pip install 'skillbank[plan]'``.

    Examples
    --------
    >>> d = ("(define (domain d) (:requirements :strips :typing) (:types button) "
    ...      "(:predicates (pressed ?b - button)) "
    ...      "(:action press :parameters (?b - button) :effect (pressed ?b)))")
    >>> p = "(define (problem p) (:domain d) (:objects b1 b2 - button) (:init) (:goal (and (pressed b2))))"
    >>> solve(d, p)
    [('press', ('b2',))]
    """
    jp = planner()
    with tempfile.TemporaryDirectory(prefix="skillbank-plan-") as tmp:
        # jupyddl reads files: the same text the user can inspect beside the plot
        (Path(tmp) / "domain.pddl").write_text(domain)
        (Path(tmp) / "problem.pddl").write_text(problem)
        try:
            task = jp.build_task(str(Path(tmp) / "domain.pddl"), str(Path(tmp) / "problem.pddl"))
        except jp.PDDLError as exc:
            raise ValueError(f"planner: the PDDL was refused: {' '.join(str(exc).split())}") from None
    missing = _unreachable(task)
    if missing:
        raise ValueError(f"goal: no plan reaches {summarise(missing)}: no sequence of the skills' actions "
                         f"makes {'it' if len(missing) == 1 else 'them'} true from the initial facts")
    result = jp.solve_task(task, "astar", "lmcut", max_expansions=max_expansions)
    if not result.solved:
        if result.stats.truncated:
            raise ValueError(f"goal: the planner gave up after {max_expansions} states without a plan")
        goals = sorted(task.fact_name(f) for f in task.goals)
        raise ValueError(f"goal: no plan reaches {summarise(goals)} together: each fact is reachable, but no "
                         "sequence of the skills' actions makes them true at once")
    return [_step(op.name) for op in result.plan]
