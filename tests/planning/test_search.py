"""skillbank's satisficing search (grounding by relaxed reachability, GBFS with h_ff) against jupyddl's A*."""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from skillbank.planning import SEARCHES, solve, solve_with_info
from skillbank.planning._pddl import atoms_of, parse_domain, parse_sexpr

from .conftest import button_scene, write_scene

REACH = """(define (domain reach) (:requirements :strips :typing) (:types target)
  (:predicates (at ?t - target) (reached ?t - target))
  (:action reach :parameters (?from ?to - target) :precondition (and (at ?from))
    :effect (and (at ?to) (reached ?to) (not (at ?from)))))
"""
PRESS = """(define (domain ordered) (:requirements :strips :typing) (:types button)
  (:predicates (ready ?b - button) (next ?a ?b - button) (pressed ?b - button))
  (:action press :parameters (?b ?n - button)
    :precondition (and (ready ?b) (next ?b ?n))
    :effect (and (pressed ?b) (ready ?n) (not (ready ?b)))))
"""
# a locked button must be unlocked (with its key) before it is pressed; a button is pressed once
LOCKS = """(define (domain locks) (:requirements :strips :typing :negative-preconditions)
  (:types button)
  (:predicates (pressed ?b - button) (locked ?b - button) (key ?b - button) (held ?b - button))
  (:action take :parameters (?b - button) :precondition (and (key ?b) (not (held ?b)))
    :effect (and (held ?b)))
  (:action unlock :parameters (?b - button) :precondition (and (held ?b) (locked ?b))
    :effect (and (not (locked ?b)) (not (held ?b))))
  (:action press :parameters (?b - button) :precondition (and (not (pressed ?b)) (not (locked ?b)))
    :effect (and (pressed ?b))))
"""


def reach_problem(n: int) -> str:
    objects = " ".join(["start"] + [f"t{k}" for k in range(n)])
    goal = " ".join(f"(reached t{k})" for k in range(n))
    return (f"(define (problem r) (:domain reach) (:objects {objects} - target) (:init (at start)) "
            f"(:goal (and {goal})))")


def press_problem(n: int) -> str:
    names = [f"b{k}" for k in range(n)]
    order = names[::2] + names[1::2]  # every other button, then the rest: an order the names do not give
    init = [f"(ready {order[0]})"] + [f"(next {a} {b})" for a, b in zip(order, order[1:] + order[-1:],
                                                                          strict=True)]
    goal = " ".join(f"(pressed {m})" for m in names)
    return (f"(define (problem p) (:domain ordered) (:objects {' '.join(names)} - button) "
            f"(:init {' '.join(init)}) (:goal (and {goal})))")


def _typed(items) -> dict:
    out, pending = {}, []
    it = iter(items)
    for tok in it:
        if tok == "-":
            kind = next(it)
            out.update(dict.fromkeys(pending, kind))
            pending = []
        else:
            pending.append(tok)
    out.update(dict.fromkeys(pending, "object"))
    return out


def simulate(domain: str, problem: str, plan) -> bool:
    """Whether ``plan`` is applicable step by step from the problem's init and ends with its goal true.

    Independent of the grounding under test: each step's action is read from
    the domain, its parameters bound to the step's arguments (of fitting type).
    """
    dom = parse_domain(domain)
    expr = parse_sexpr(problem)
    parts = {p[0]: p[1:] for p in expr[2:]}
    objects = _typed(parts.get(":objects", []))
    types = {}
    for part in parse_sexpr(domain)[2:]:
        if part[:1] == [":types"]:
            types = _typed(part[1:])
        if part[:1] == [":constants"]:
            objects.update(_typed(part[1:]))
    state = {(a[0], tuple(a[1:])) for a in parts.get(":init", [])}
    for name, args in plan:
        action = dom.actions[name]
        if len(args) != len(action.parameters):
            return False
        binding = dict(zip((p for p, _ in action.parameters), args, strict=True))
        for (_, wanted), obj in zip(action.parameters, args, strict=True):
            kind = objects.get(obj)
            while kind not in (wanted, None) and wanted != "object":
                kind = types.get(kind)  # up the hierarchy; None past its top
            if kind is None and wanted != "object":
                return False

        def ground(atom, binding=binding):
            return atom[1], tuple(binding.get(a, a) for a in atom[2])

        for atom in atoms_of(action.precondition, "pre"):
            if (ground(atom) in state) == atom[0]:
                return False
        effect = atoms_of(action.effect, "eff")
        state -= {ground(a) for a in effect if a[0]}
        state |= {ground(a) for a in effect if not a[0]}
    return all(((pred, args) in state) != neg for neg, pred, args in atoms_of(parts[":goal"][0], "goal"))


@pytest.mark.parametrize("n", range(3, 9))
@pytest.mark.parametrize("kind", ["reach", "press"])
def test_plans_are_as_short_as_a_star_with_lm_cut_on_small_tasks(kind, n):
    domain, problem = (REACH, reach_problem(n)) if kind == "reach" else (PRESS, press_problem(n))
    plan = solve(domain, problem)
    best = solve(domain, problem, search="optimal")
    assert len(plan) == len(best) == n
    assert simulate(domain, problem, plan) and simulate(domain, problem, best)


def test_negative_preconditions_are_planned_like_a_star_plans_them():
    problem = ("(define (problem p) (:domain locks) (:objects b1 b2 b3 - button) "
               "(:init (locked b2) (key b2) (pressed b3)) "
               "(:goal (and (pressed b1) (pressed b2) (pressed b3))))")
    plan = solve(LOCKS, problem)
    assert simulate(LOCKS, problem, plan)
    assert len(plan) == len(solve(LOCKS, problem, search="optimal")) == 4  # take, unlock, press, press
    with pytest.raises(ValueError, match=r"^goal: no plan reaches \(pressed b2\): no sequence"):
        solve(LOCKS, problem.replace("(key b2)", ""))  # no key: b2 stays locked


def test_hundreds_of_places_are_planned_and_the_plan_holds():
    n = 320
    problem = reach_problem(n)
    plan, info = solve_with_info(REACH, problem)
    assert len(plan) == n and simulate(REACH, problem, plan)
    assert info["search"] == "satisficing" and info["planner"] == SEARCHES["satisficing"]
    assert info["expanded"] == n  # helpful actions lead straight to the goal


def test_static_facts_bind_parameters_from_the_initial_facts():
    from skillbank.planning._search import ground  # the grounding under test

    task = ground(PRESS, press_problem(200))
    assert len(task.names) == 200  # one press per (next ?b ?n) fact, not 200^2 pairs
    assert all(name.startswith(("(pressed", "(ready")) for name in task.facts)


def test_an_unreachable_goal_and_a_goal_unreachable_together_are_told_apart():
    init = "(ready b3) (next b3 b1)"
    problem = ("(define (problem p) (:domain ordered) (:objects b1 b2 b3 b4 - button) (:init {}) "
               "(:goal (and {})))")
    with pytest.raises(ValueError, match=r"^goal: no plan reaches \(pressed b1\), \(pressed b2\), "
                                         r"\(pressed b4\): no sequence of the skills' actions makes them"):
        solve(PRESS, problem.format(init, "(pressed b3) (pressed b1) (pressed b4) (pressed b2)"))
    init = "(ready b1) (next b1 b2) (next b1 b3) (next b2 b4) (next b3 b4)"
    with pytest.raises(ValueError, match=r"^goal: no plan reaches \(pressed b2\), \(pressed b3\) together: "
                                         r"each fact is reachable"):
        solve(PRESS, problem.format(init, "(pressed b2) (pressed b3)"))


def test_the_budgets_and_the_search_name_are_checked():
    with pytest.raises(ValueError, match=r"^goal: the planner gave up after 3 states without a plan "
                                         r"\(max_expansions\)$"):
        solve(PRESS, press_problem(8), max_expansions=3)
    with pytest.raises(ValueError, match=r"^goal: the planner gave up after 1e-09 s without a plan \(0 "
                                         r"states\)"):
        solve(REACH, reach_problem(40), time_limit=1e-9)
    with pytest.raises(ValueError, match=r"^search: expected one of 'satisficing', 'optimal', got 'fast'$"):
        solve(REACH, reach_problem(3), search="fast")


def test_the_optimal_search_is_jupyddls_a_star_and_finds_the_shortest_plan():
    # two routes to (done): a long one the greedy search may take, a short one through (shortcut)
    domain = """(define (domain routes) (:requirements :strips :typing) (:types place)
      (:predicates (at ?p - place) (link ?a ?b - place) (done))
      (:action go :parameters (?a ?b - place) :precondition (and (at ?a) (link ?a ?b))
        :effect (and (at ?b) (not (at ?a))))
      (:action finish :parameters (?p - place) :precondition (and (at ?p) (link ?p ?p)) :effect (done)))"""
    problem = ("(define (problem p) (:domain routes) (:objects a b c d e - place) (:init (at a) (link a b) "
               "(link b c) (link c d) (link d e) (link e e) (link a e)) (:goal (and (done))))")
    steps, info = solve_with_info(domain, problem, search="optimal")
    assert steps == [("go", ("a", "e")), ("finish", ("e",))]
    assert info["planner"] == "A* with LM-cut (jupyddl)" and info["expanded"] >= 1
    assert simulate(domain, problem, solve(domain, problem))


def test_pddl_outside_the_subset_is_refused_in_one_line():
    for goal in ("(forall b1)", "(and)", "(or (pressed b1))"):
        problem = ("(define (problem p) (:domain ordered) (:objects b1 - button) (:init) "
                   f"(:goal (and {goal})))")
        with pytest.raises(ValueError, match=r"^planner: the PDDL was refused: ") as info:
            solve(PRESS, problem)
        assert "\n" not in str(info.value)
    assert solve(PRESS, "(define (problem p) (:domain ordered) (:objects b1 - button) (:init) "
                        "(:goal (and)))") == []


@st.composite
def strips_problems(draw):
    """A random STRIPS problem over 3 objects of 2 types (one a subtype), with negative preconditions."""
    preds = {"p": 1, "q": 1, "r": 2}
    objects = {"a": "thing", "b": "thing", "c": "tool"}
    actions = []
    for k in range(draw(st.integers(1, 3))):
        params = [f"?x{j}" for j in range(draw(st.integers(0, 2)))]
        kinds = [draw(st.sampled_from(["thing", "tool"])) for _ in params]

        def atom(params=params):
            pred = draw(st.sampled_from(sorted(preds)))
            args = [draw(st.sampled_from(params + ["c"])) for _ in range(preds[pred])]
            return f"({pred} {' '.join(args)})".replace(" )", ")")

        pre = [atom() for _ in range(draw(st.integers(0, 2)))]
        pre += [f"(not {atom()})" for _ in range(draw(st.integers(0, 1)))]
        eff = [atom() for _ in range(draw(st.integers(1, 2)))]
        eff += [f"(not {atom()})" for _ in range(draw(st.integers(0, 1)))]
        typed = " ".join(f"{p} - {t}" for p, t in zip(params, kinds, strict=True))
        actions.append(f"(:action act{k} :parameters ({typed}) :precondition (and {' '.join(pre)}) "
                       f":effect (and {' '.join(eff)}))")
    ground = [f"(p {o})" for o in objects] + [f"(q {o})" for o in objects] + \
        [f"(r {o} {o2})" for o in objects for o2 in objects]
    init = draw(st.lists(st.sampled_from(ground), max_size=4, unique=True))
    goal = draw(st.lists(st.sampled_from(ground), min_size=1, max_size=3, unique=True))
    domain = ("(define (domain rnd) (:requirements :strips :typing :negative-preconditions) "
              "(:types tool - thing) (:constants c - tool) " + " ".join(actions) + ")")
    problem = (f"(define (problem q) (:domain rnd) (:objects a b - thing) (:init {' '.join(init)}) "
               f"(:goal (and {' '.join(goal)})))")
    return domain, problem


@settings(derandomize=True, max_examples=30, deadline=None)
@given(strips_problems())
def test_every_plan_found_on_random_problems_is_valid(task):
    domain, problem = task
    try:
        plan = solve(domain, problem)
    except ValueError as exc:
        assert str(exc).startswith("goal: no plan reaches"), exc
        plan = None
    if plan is not None:
        assert simulate(domain, problem, plan), plan
    try:  # the same verdict as the complete, optimal search: a plan exists or it does not
        best = solve(domain, problem, search="optimal")
    except ValueError:
        best = None
    assert (plan is None) == (best is None), (plan, best)
    if plan is not None:
        assert len(plan) >= len(best)


def test_cli_plan_json_names_the_planner(described_library, synthetic_db, tmp_path, cli):
    described_library.close()
    scene = write_scene(tmp_path, button_scene([[0.2, 0.0, 0.0], [0.0, 0.2, 0.0]], goal=["b1", "b2"]))
    for search in ("satisficing", "optimal"):
        code, out, err = cli("plan", synthetic_db, "--scene", scene, "--json", "--search", search)
        assert code == 0, err
        doc = json.loads(out)
        assert doc["planner"] == {"search": search, "name": SEARCHES[search]}
        assert len(doc["plan"]) == 2


def test_the_bound_on_ground_actions_counts_what_is_reachable():
    from skillbank.planning import MAX_GROUNDINGS, check_groundings, parse_domain  # the bound and the count

    n = 320
    problem = press_problem(n)
    domain = parse_domain(PRESS)
    objects = {f"b{k}": "button" for k in range(1, n + 1)}
    # every pair of buttons is (n^2 = 102400) over the bound; only the n that (next ?b ?n) allows are built
    with pytest.raises(ValueError, match="got 102400 in this scene"):
        check_groundings(domain, objects)
    plan = solve(PRESS, problem, max_groundings=MAX_GROUNDINGS)
    assert len(plan) == n
    with pytest.raises(ValueError, match=r"^domain: expected at most max_groundings=100 ground actions "
                                         r"reachable from the initial facts, got more; .*--max-groundings"):
        solve(PRESS, problem, max_groundings=100)
    with pytest.raises(ValueError, match=r"^max_groundings: expected an integer > 0"):
        solve(PRESS, problem, max_groundings=0)


def test_the_satisficing_search_has_its_own_bound_on_what_is_reachable(monkeypatch):
    from skillbank.planning import MAX_GROUNDINGS, MAX_REACHABLE_GROUNDINGS, _solve

    n = 320  # (n + 1)^2 = 103041 moves, every one reachable: over the optimal search's bound, under this one
    assert (n + 1) ** 2 > MAX_GROUNDINGS and (n + 1) ** 2 < MAX_REACHABLE_GROUNDINGS
    plan = solve(REACH, reach_problem(n))
    assert len(plan) == n and {args[-1] for _, args in plan} == {f"t{k}" for k in range(n)}
    monkeypatch.setattr(_solve, "MAX_REACHABLE_GROUNDINGS", 1000)
    with pytest.raises(ValueError, match=r"^domain: expected at most max_groundings=1000 ground actions "
                                         r"reachable"):
        solve(REACH, reach_problem(40))
