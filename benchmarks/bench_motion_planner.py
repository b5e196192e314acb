"""The motion planner (issue 43, item 1): plans with and without it on wall and shelf scenes, and OMPL's
planners compared on the same transits.

Two buttons 50-60 cm apart on a table in front of the UR5e, the three-button skill's press (b1 to b2),
the whole robot checked with a 5 mm margin; between the buttons a wall 32-45 cm high (once with a post
over it), or a 30 cm wall with a shelf 8 cm over it. Each scene is planned twice in the same run:
``planner="none"`` (the skill with its whole-arm repairs, as before) and ``"ompl"`` (the default: the
same, then the motion planner when they cannot keep the robot clear). Every plan returned is checked
again for the whole robot. Then the transits the planner carried are planned again directly with
:func:`skillbank.robots.plan_motion` by RRTConnect, LBKPIECE1 and KPIECE1 over ``--seeds`` seeds:
success and planning time (the search, then the simplification).

    PYTHONPATH=. python benchmarks/bench_motion_planner.py [--seeds 5] [--json]
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import tempfile
import time
from pathlib import Path

from _common import data_dir
from bench_whole_arm_repair import library  # the three-button skill and its press

from skillbank.core import parse_obstacle
from skillbank.planning import arm_clearance, plan_task, scene_from_dict
from skillbank.robots import MotionPlanningError, plan_motion, robot_model

DOWN = [0.0, 1.0, 0.0, 0.0]
SCENES = {
    "wall 32 cm": ({"wall": "box:-0.6,-0.02,0.0,-0.3,0.02,0.32"}, 0.3),
    "wall 36 cm": ({"wall": "box:-0.6,-0.02,0.0,-0.3,0.02,0.36"}, 0.3),
    "wall 40 cm": ({"wall": "box:-0.6,-0.02,0.0,-0.3,0.02,0.4"}, 0.3),
    "wall 45 cm": ({"wall": "box:-0.6,-0.02,0.0,-0.3,0.02,0.45"}, 0.3),
    "wall 40 cm, buttons 50 cm apart": ({"wall": "box:-0.6,-0.02,0.0,-0.3,0.02,0.4"}, 0.25),
    "wall 32 cm and a post": ({"wall": "box:-0.6,-0.02,0.0,-0.3,0.02,0.32",
                               "post": "sphere:-0.2,0.0,0.45,0.04"}, 0.3),
    "wall 30 cm, shelf at 38 cm": ({"wall": "box:-0.6,-0.02,0.0,-0.3,0.02,0.3",
                                    "shelf": "box:-0.75,-0.12,0.38,-0.35,0.12,0.41"}, 0.3),
    "wall 25 cm, shelf at 45 cm": ({"wall": "box:-0.6,-0.02,0.0,-0.3,0.02,0.25",
                                    "shelf": "box:-0.7,-0.12,0.45,-0.3,0.12,0.48"}, 0.3),
}
PLANNERS = ("rrtconnect", "lbkpiece", "kpiece")


def scene_doc(obstacles, y) -> dict:
    return {"objects": {"b1": {"type": "button", "position": [-0.45, -y, 0.03], "orientation": DOWN},
                        "b2": {"type": "button", "position": [-0.45, y, 0.03], "orientation": DOWN}},
            "obstacles": obstacles, "table": {"height": 0.0},
            "init": ["(free b1)", "(free b2)"], "goal": ["(pressed b2)"],
            "start": {"position": [-0.45, -y, 0.08], "orientation": DOWN}}


def plan(lib, scene, planner, model):
    t0 = time.perf_counter()
    try:
        res = plan_task(lib.store, scene, robot="ur5e", planner=planner, random_state=0)
    except ValueError as exc:
        return {"ok": False, "seconds": time.perf_counter() - t0, "why": " ".join(str(exc).split())[:160]}
    seconds = time.perf_counter() - t0
    J = res.trajectory["joints"]
    check = arm_clearance(model, scene, list(scene.obstacles), J, objects=["b1"])
    note = next((n for n in res.notes if "the motion planner (OMPL" in n), None)
    search = None if note is None else float(re.search(r"carried the move in ([\d.e-]+) s", note).group(1))
    transit = None
    if note is not None:
        seg = res.steps[0].segments[0]
        transit = (J[seg["start"]], J[seg["stop"] - 1])
    return {"ok": True, "seconds": seconds, "clearance_mm": 1000 * check.min_distance, "safe":
            check.min_distance >= 0.005 - 1e-9, "planned": note is not None, "search_s": search,
            "duration_s": float(res.trajectory.t[-1]), "transit": transit}


def compare(model, scene, transit, seeds):
    world = dict(obstacles=dict(scene.obstacles), table=scene.table, workspace=scene.workspace)
    out = {}
    for name in PLANNERS:
        rows = []
        for seed in range(seeds):
            try:
                p = plan_motion(model, *transit, random_state=seed, planner=name, **world)
                rows.append((True, p.planning_time, p.simplify_time, p.length))
            except MotionPlanningError:
                rows.append((False, None, None, None))
        done = [r for r in rows if r[0]]
        out[name] = {"solved": len(done), "runs": len(rows),
                     "median_search_s": statistics.median(r[1] for r in done) if done else None,
                     "max_search_s": max(r[1] for r in done) if done else None,
                     "median_simplify_s": statistics.median(r[2] for r in done) if done else None,
                     "median_length_rad": statistics.median(r[3] for r in done) if done else None}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--data", default=None)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    model = robot_model("ur5e")
    report = {}
    with tempfile.TemporaryDirectory() as tmp:
        lib = library(Path(tmp), data_dir(args.data))
        for name, (obstacles, y) in SCENES.items():
            for spec in obstacles.values():
                parse_obstacle(spec)
            scene = scene_from_dict(scene_doc(obstacles, y))
            row = {"none": plan(lib, scene, "none", model), "ompl": plan(lib, scene, "ompl", model)}
            transit = row["ompl"].pop("transit", None)
            row["none"].pop("transit", None)
            if transit is not None:
                row["planners"] = compare(model, scene, transit, args.seeds)
            report[name] = row
            if not args.json:
                print(f"{name}: none {'ok' if row['none']['ok'] else 'refused'} "
                      f"({row['none']['seconds']:.1f} s), ompl {'ok' if row['ompl']['ok'] else 'refused'} "
                      f"({row['ompl']['seconds']:.1f} s" + (f", search {row['ompl']['search_s']:.3g} s, "
                                                              f"clear {row['ompl']['clearance_mm']:.1f} mm"
                                                              if row["ompl"].get("planned") else "") + ")")
                for p, r in row.get("planners", {}).items():
                    med = "-" if r["median_search_s"] is None else f"{r['median_search_s']:.3g} s"
                    print(f"    {p}: {r['solved']}/{r['runs']}, median search {med}")
        lib.close()
    if args.json:
        print(json.dumps(report, indent=1))

if __name__ == "__main__":
    main()
