"""Plans of hundreds of objects: skillbank's GBFS with h_ff against jupyddl's A*/LM-cut and GBFS.

Run from the repository root (jupyddl, the ``plan`` extra, for the comparison)::

    .venv/bin/python benchmarks/bench_planning_search.py [--sizes 10 20 40 80 160 320] [--budget 10]
        [--json PATH]

Two domains, each at N = 10 ... 320 objects, written as PDDL text:

- *reach*: N targets to visit in any order from a start,
  ``(reach ?from ?to - target)`` moves ``at`` and marks ``reached``: N + 1
  objects, (N + 1)^2 ground actions, 2^N states an optimal search may expand;
- *press*: N buttons pressed in an order the initial facts impose (every
  other button, then the rest: ``(next ?b ?n)``), the press domain of
  benchmarks/bench_planning.py: N ground actions once ``next`` is looked up
  in the initial facts, N^2 when every pair of buttons is grounded.

For each case: ``solve(..., search="satisficing")`` (grounding and search, the
plan's length and the states expanded), and jupyddl: its grounding
(``build_task``, once), then A* with LM-cut (``search="optimal"``) and its
own GBFS with h_ff, each given ``--budget`` seconds. A planner that runs out
of its budget is not run at the larger N of that domain, and jupyddl is not
run where its grounding alone (extrapolated from the rate measured at the
domain's previous N) would exceed the budget. pyperplan (GPL) is run as an external program when it is
installed, never imported. No timing is asserted.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from skillbank.planning import parse_domain, solve_with_info
from skillbank.planning._solve import check_groundings, planner

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
#: jupyddl's grounding cost per ground action before one is measured (skillbank/planning/_solve.py), to skip
#: a case whose grounding alone cannot fit the budget; then the rate measured at the domain's last N.
JUPYDDL_SECONDS_PER_ACTION = 2e-4


def reach_case(n: int) -> tuple:
    objects = {"start": "target", **{f"t{k}": "target" for k in range(n)}}
    goal = " ".join(f"(reached t{k})" for k in range(n))
    problem = (f"(define (problem r) (:domain reach) (:objects {' '.join(objects)} - target) "
               f"(:init (at start)) (:goal (and {goal})))")
    return REACH, problem, objects


def press_case(n: int) -> tuple:
    names = [f"b{k}" for k in range(n)]
    order = names[::2] + names[1::2]
    init = [f"(ready {order[0]})"] + [f"(next {a} {b})" for a, b in zip(order, order[1:] + order[-1:],
                                                                          strict=True)]
    goal = " ".join(f"(pressed {m})" for m in names)
    problem = (f"(define (problem p) (:domain ordered) (:objects {' '.join(names)} - button) "
               f"(:init {' '.join(init)}) (:goal (and {goal})))")
    return PRESS, problem, dict.fromkeys(names, "button")


CASES = {"reach": reach_case, "press": press_case}


def _jupyddl(jp, domain, problem, budget, searches):
    """jupyddl's grounding once, then each of ``searches`` ((name, search, heuristic)) within ``budget``."""
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / "d.pddl").write_text(domain)
        (Path(tmp) / "p.pddl").write_text(problem)
        start = time.perf_counter()
        task = jp.build_task(str(Path(tmp) / "d.pddl"), str(Path(tmp) / "p.pddl"))
        out["ground_s"] = time.perf_counter() - start
    for name, search, heuristic in searches:
        start = time.perf_counter()
        result = jp.solve_task(task, search, heuristic, time_limit=budget)
        seconds = time.perf_counter() - start
        out[name] = {"s": seconds, "length": len(result.plan) if result.solved else None,
                     "expanded": result.stats.expanded, "timed_out": not result.solved}
    return out


def _pyperplan(domain, problem, budget):
    """pyperplan (GPL) as an external program, when installed: GBFS with h_ff, or None."""
    exe = shutil.which("pyperplan")
    if exe is None and not _pyperplan_module():
        return None
    cmd = [exe] if exe else [sys.executable, "-m", "pyperplan"]
    with tempfile.TemporaryDirectory() as tmp:
        d, p = Path(tmp) / "d.pddl", Path(tmp) / "p.pddl"
        d.write_text(domain)
        p.write_text(problem)
        start = time.perf_counter()
        try:
            run = subprocess.run([*cmd, "-H", "hff", "-s", "gbf", str(d), str(p)], capture_output=True,
                                 timeout=budget, check=False)
        except subprocess.TimeoutExpired:
            return {"s": budget, "length": None, "timed_out": True}
        seconds = time.perf_counter() - start
        soln = Path(str(p) + ".soln")
        length = sum(1 for line in soln.read_text().splitlines() if line.strip()) if soln.exists() else None
        return {"s": seconds, "length": length, "timed_out": run.returncode != 0 or length is None}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[10, 20, 40, 80, 160, 320])
    parser.add_argument("--budget", type=float, default=10.0,
                        help="seconds each of jupyddl's searches (and pyperplan) may take per case")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args(argv)
    try:
        jp = planner()
    except ImportError as exc:
        jp = None
        print(f"jupyddl: not installed ({exc}); skillbank's search only")
    pyperplan_found = shutil.which("pyperplan") is not None or _pyperplan_module()
    if not pyperplan_found:
        print("pyperplan: not installed (GPL; run as an external program when it is): not compared")
    searches = [("astar_lmcut", "astar", "lmcut"), ("gbfs_hff", "gbfs", "hff")]
    rows = []
    for kind, case in CASES.items():
        out_of_budget = set()
        rate = JUPYDDL_SECONDS_PER_ACTION
        for n in args.sizes:
            domain, problem, objects = case(n)
            steps, info = solve_with_info(domain, problem, search="satisficing")
            row = {"domain": kind, "n": n, "skillbank": {"s": info["seconds"], "length": len(steps),
                                                         "expanded": info["expanded"]}}
            grounded = check_groundings(parse_domain(domain), objects, max_groundings=10 ** 12)
            row["ground_actions"] = grounded
            todo = [s for s in searches if s[0] not in out_of_budget]
            if jp is not None and todo and grounded * rate > args.budget:
                row["jupyddl"] = f"skipped: grounding ~{grounded * rate:.0f} s"
            elif jp is not None and todo:
                row["jupyddl"] = _jupyddl(jp, domain, problem, args.budget, todo)
                rate = max(row["jupyddl"]["ground_s"] / grounded, 1e-6)
                out_of_budget |= {name for name, *_ in todo if row["jupyddl"][name]["timed_out"]}
            if pyperplan_found and "pyperplan" not in out_of_budget:
                row["pyperplan"] = _pyperplan(domain, problem, args.budget)
                if row["pyperplan"] is None or row["pyperplan"]["timed_out"]:
                    out_of_budget.add("pyperplan")
            rows.append(row)
            _print(row)
    if args.json is not None:
        args.json.write_text(json.dumps({"budget_s": args.budget, "platform": sys.platform, "rows": rows},
                                        indent=1))


def _pyperplan_module() -> bool:
    import importlib.util  # only to look for it: pyperplan is GPL, run as a program and never imported

    return importlib.util.find_spec("pyperplan") is not None


def _cell(res) -> str:
    if res is None:
        return "-"
    if res.get("length") is None:
        return f"gave up after {res['s']:.1f} s"
    return f"{res['s']:.3f} s, {res['length']} steps"


def _print(row):
    jd = row.get("jupyddl")
    if isinstance(jd, dict):
        ground = f"{jd['ground_s']:.2f} s"
        astar, gbfs = _cell(jd.get("astar_lmcut")), _cell(jd.get("gbfs_hff"))
    else:
        ground, astar, gbfs = jd or "-", "-", "-"
    sb = row["skillbank"]
    line = (f"{row['domain']:<5} N={row['n']:<4} skillbank GBFS/h_ff: {sb['s']:.3f} s, {sb['length']} steps "
            f"({sb['expanded']} states) | jupyddl ground: {ground}; A*/LM-cut: {astar}; GBFS/h_ff: {gbfs}")
    if "pyperplan" in row:
        line += f" | pyperplan: {_cell(row['pyperplan'])}"
    print(line, flush=True)


if __name__ == "__main__":
    main()
