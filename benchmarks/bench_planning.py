"""Planning and chained reproduction of a 10-step task: time per step, against plain reuse.

Run from the repository root (needs ``skillbank[plan]``)::

    .venv/bin/python benchmarks/bench_planning.py [--steps 10] [--repeats 3] [--json PATH]

Case: a library of three synthetic 'press' primitives (lift 5 cm, move 20 cm, press down; 60
samples, orientation tool-down, gripper), described with an ordered press action
``(press ?b ?next)`` whose facts force one order; a scene of N buttons on a circle of radius
0.15 m around (0.35, -0.35, 0.2) in the UR5e's base frame, all to be pressed. Timed (best of
the repeats), in one run:

- planning: writing the domain and problem and solving them (A* with LM-cut);
- chained reproduction without and with the UR5e's joints (``plan_task`` less planning);
- baseline: the same N steps as independent ``selection.reuse`` calls with the constraints the
  chain used (what a user would do by hand), so the ratio is the cost of the chaining.

No timing is asserted.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from skillbank import Constraints, Demonstration
from skillbank.pipeline import Library
from skillbank.planning import plan_task, scene_from_dict, solve
from skillbank.planning._pddl import problem_text
from skillbank.planning._plan import _domain
from skillbank.selection import reuse

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import best_of  # noqa: E402

ACTION = ("(:action press :parameters (?b ?n - button) :precondition (and (ready ?b) (next ?b ?n)) "
          ":effect (and (pressed ?b) (ready ?n) (not (ready ?b))))")
DOWN = [1.0, 0.0, 0.0, 0.0]


def _press(travel, n=60):
    s = np.linspace(0.0, 1.0, n)
    ease = 0.5 - 0.5 * np.cos(np.pi * s)
    P = np.outer(ease, travel) + np.c_[0 * s, 0 * s, 0.05 * np.sin(np.pi * s)]
    streams = {"position": P, "orientation": np.tile(DOWN, (n, 1)), "gripper": np.ones((n, 1))}
    return Demonstration(2.0 * s, streams)


def _scene(n):
    angles = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    pts = np.c_[0.35 + 0.15 * np.cos(angles), -0.35 + 0.15 * np.sin(angles), np.full(n, 0.2)]
    names = [f"b{k}" for k in range(n)]
    order = names[::2] + names[1::2]  # an order no demonstration had: every other button, then the rest
    init = [f"(ready {order[0]})"] + [f"(next {a} {b})" for a, b in zip(order, order[1:] + [order[-1]],
                                                                          strict=True)]
    return {"objects": {m: {"type": "button", "position": p.tolist(), "orientation": DOWN}
                        for m, p in zip(names, pts, strict=True)},
            "init": init, "goal": [f"(pressed {m})" for m in names],
            "start": {"position": pts[0].tolist(), "orientation": DOWN}}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--steps", type=int, default=10)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp, Library(Path(tmp) / "bench.db") as lib:
        for travel in ([0.2, 0.0, 0.0], [0.0, 0.2, 0.0], [0.15, 0.1, 0.0]):
            lib.add(_press(np.array(travel)), segment=False, label="press")
        lib.describe("press", ACTION, {"goal": "?b"})
        scene = scene_from_dict(_scene(args.steps))
        dom = _domain(lib.store, scene, None)
        problem = problem_text({m: o.type for m, o in scene.objects.items()}, scene.init, scene.goal,
                               domain=dom.name)
        t_plan, steps = best_of(lambda: solve(dom.text, problem), args.repeats)
        t_chain, res = best_of(lambda: plan_task(lib.store, scene), args.repeats)
        t_robot, res_robot = best_of(lambda: plan_task(lib.store, scene, robot="ur5e"), args.repeats)
        prims = lib.primitives(label="press")
        P = res.trajectory["position"]
        rest = np.zeros(3)
        tasks = [Constraints(start=P[s.start], goal=s.goal, start_velocity=rest, end_velocity=rest,
                             start_orientation=DOWN, goal_orientation=DOWN) for s in res.steps]

        def baseline():
            return [reuse([p.demo for p in prims], c, method="lte", ids=[p.id for p in prims]) for c in tasks]

        t_base, _ = best_of(baseline, args.repeats)
    n = len(steps)
    rows = [("planning (domain + problem + A*/LM-cut)", t_plan),
            ("chained reproduction (plan_task - planning)", t_chain - t_plan),
            ("chained reproduction with UR5e joints", t_robot - t_plan),
            ("baseline: independent reuse calls", t_base)]
    print(f"{n}-step task ({len(P)} samples, {res.trajectory.t[-1]:.1f} s; joins: position "
          f"{res.join_error['position']:.1e}, orientation {res.join_error['orientation']:.1e} rad, joints "
          f"{res_robot.join_error['joints']:.1e} rad), best of {args.repeats}, {sys.platform}")
    print(f"| {'what':<46} | total (s) | per step (ms) |")
    print(f"|{'-' * 48}|-----------|---------------|")
    for what, t in rows:
        print(f"| {what:<46} | {t:9.4f} | {1000 * t / n:13.2f} |")
    print(f"chaining / baseline: {(t_chain - t_plan) / t_base:.2f}x")
    if args.json is not None:
        args.json.write_text(json.dumps({"steps": n, "rows": {w: t for w, t in rows}}, indent=1))


if __name__ == "__main__":
    main()
