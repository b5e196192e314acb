"""A start the arm can take (issue 41): how many starts given as a tool position alone plan.

Three buttons in a row on a table in front of the UR5e (x = -0.45 m, y = -0.2, 0, 0.2, the tool down),
pressed in any order with the three-button skill; the scene's start is a position alone, on a grid of
27 points (x in -0.6, -0.45, -0.3; y in -0.2, 0, 0.2; z 0.15, 0.25, 0.35 m above the table, raised by
the 2F-85's 0.163 m TCP with ``--tool flange``). Each is planned with the whole-robot check (5 mm), and
the failures are counted by kind: a start inside the robot itself or the scene (what the recorded
branch gave before issue 41), no clear start on any branch (the one-line refusal now), or a later step.
Run it on two checkouts to compare:

    PYTHONPATH=. python benchmarks/bench_start_pose.py [--tool flange] [--json]
"""

from __future__ import annotations

import argparse
import itertools
import json
import tempfile
import time
from pathlib import Path

from _common import data_dir
from bench_whole_arm_repair import DOWN, library  # the same three-button skill and its press

from skillbank.planning import arm_clearance, plan_task, scene_from_dict
from skillbank.robots import robot_model

TCP = 0.163


def scene_doc(start, lift) -> dict:
    names = ["b1", "b2", "b3"]
    return {"objects": {n: {"type": "button", "position": [-0.45, y, 0.03 + lift], "orientation": DOWN}
                        for n, y in zip(names, (-0.2, 0.0, 0.2), strict=True)},
            "table": {"height": 0.0}, "init": [f"(free {n})" for n in names],
            "goal": [f"(pressed {n})" for n in names],
            "start": {"position": [start[0], start[1], start[2] + lift]}}


def kind(message: str) -> str:
    if "starts inside" in message:
        return "start inside (recorded branch)"
    if message.startswith("start:"):
        return "no clear start on any branch"
    return "a later step: " + message.split(": ", 1)[-1][:60]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tool", default=None, help="the robot's tool (default its TCP; 'flange')")
    parser.add_argument("--data", default=None)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    lift = TCP if args.tool == "flange" else 0.0
    model = robot_model("ur5e", tool=args.tool)
    planned, failures, starts, t0 = 0, {}, [], time.perf_counter()
    grid = list(itertools.product([-0.6, -0.45, -0.3], [-0.2, 0.0, 0.2], [0.15, 0.25, 0.35]))
    with tempfile.TemporaryDirectory() as tmp:
        lib = library(Path(tmp), data_dir(args.data))
        try:
            for start in grid:
                scene = scene_from_dict(scene_doc(start, lift))
                try:
                    res = plan_task(lib.store, scene, robot=model)
                except ValueError as exc:
                    failures[kind(str(exc))] = failures.get(kind(str(exc)), 0) + 1
                    continue
                planned += 1
                first = res.trajectory["joints"][:1]
                starts.append(float(arm_clearance(model, scene, [], first).min_distance))
        finally:
            lib.close()
    out = {"tool": args.tool or "tcp", "starts": len(grid), "planned": planned, "failures": failures,
           "min_start_clearance": min(starts) if starts else None, "seconds": time.perf_counter() - t0}
    print(json.dumps(out) if args.json else
          f"{out['tool']}: {planned}/{len(grid)} planned; failures {failures}; smallest start clearance "
          f"{1000 * out['min_start_clearance']:.3g} mm; {out['seconds']:.0f} s")


if __name__ == "__main__":
    main()
