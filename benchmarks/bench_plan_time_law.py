"""A plan's duration under the time law (issue 43, item 4): planned chains on the UR5e, total and per step.

Three plans with the paper's three-button press skill, ``robot="ur5e"``, seed 0:

1. the README's four new buttons around a post (``experiments._planning_demo.button_task``'s library and
   scene, at most 1 rad/s per joint);
2. docs/planning.md's ``scene.json`` (one button, a ball over the path; the presses 2, 3, 4 labelled);
3. docs/planning.md's ``tall_wall.json`` (a 40 cm wall: the move planned by OMPL).

For each: the trajectory's duration, each step's, the samples, and ``rate_ratio`` of its joints against the
limits it was timed for (<= 1: within, as the exports measure them), and the notes that say how each step
was timed (the time law's note gives the uniform stretch's duration too). Run it on two checkouts to
compare (the script uses the public API and the notes only):

    PYTHONPATH=. python benchmarks/bench_plan_time_law.py [--data DIR]

No timing is asserted.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
from _common import data_dir

from skillbank.experiments._planning_demo import _button_library, button_scene
from skillbank.io import read_robot_h5
from skillbank.pipeline import Library
from skillbank.robots import rate_ratio, robot_model

PRESS = """(:action press
  :parameters (?b - button)
  :precondition (free ?b)
  :effect (and (pressed ?b) (not (free ?b))))"""
DOWN = [0, 1, 0, 0]
SCENE = {"objects": {"b1": {"type": "button", "position": [0.1, -0.5, 0.15], "orientation": DOWN}},
         "obstacles": ["sphere:0.0,-0.5,0.2,0.03"], "init": ["(free b1)"], "goal": ["(pressed b1)"],
         "start": {"position": [0.0, -0.45, 0.4], "orientation": DOWN}}
WALL = {"objects": {"b1": {"type": "button", "position": [-0.45, -0.3, 0.03], "orientation": DOWN},
                    "b2": {"type": "button", "position": [-0.45, 0.3, 0.03], "orientation": DOWN}},
        "obstacles": {"wall": "box:-0.6,-0.02,0.0,-0.3,0.02,0.4"}, "table": {"height": 0.0},
        "init": ["(free b1)", "(free b2)"], "goal": ["(pressed b2)"],
        "start": {"position": [-0.45, -0.3, 0.08], "orientation": DOWN}}


def report(name, res, seconds, joint_velocity=None) -> None:
    model = robot_model("ur5e")
    velocity = model.rate_limits["joint_velocity"]
    if joint_velocity is not None:
        velocity = np.minimum(velocity, joint_velocity)
    traj = res.trajectory
    steps = [round(float(traj.t[s.stop - 1] - traj.t[s.start]), 3) for s in res.steps]
    ratio = rate_ratio(traj.t, traj["joints"], velocity=velocity,
                       acceleration=model.rate_limits["joint_acceleration"])
    print(f"{name}: {traj.t[-1]:.3f} s, steps {steps}, {traj.n_steps} samples, rate ratio {ratio:.4f}, "
          f"law {traj.metadata.get('timing', {}).get('law', '(none stated)')}, planned in {seconds:.1f} s")
    for note in res.notes:
        if "time law" in note or "stretched" in note:
            print("   ", note)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=None)
    data = data_dir(parser.parse_args().data)
    out = Path(tempfile.mkdtemp())
    with Library(out / "buttons.sqlite") as lib:
        _button_library(lib, data)
        start = time.perf_counter()
        res = lib.plan(button_scene(), robot="ur5e", limits={"joint_velocity": 1.0}, random_state=0)
        report("four buttons around a post (1 rad/s)", res, time.perf_counter() - start, 1.0)
    with Library(out / "lib.db") as lib:
        lib.add(read_robot_h5(str(data / "seed" / "three_button_pressing_demo.h5")))
        for i in (2, 3, 4):
            lib.label("press", primitive=i)
        lib.describe("press", PRESS, None)
        for name, doc in (("docs/planning.md scene.json", SCENE), ("tall_wall.json (OMPL transit)", WALL)):
            start = time.perf_counter()
            res = lib.plan(doc, robot="ur5e", random_state=0)
            report(name, res, time.perf_counter() - start)


if __name__ == "__main__":
    main()
