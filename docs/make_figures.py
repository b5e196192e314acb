"""Regenerate the README figures and its numbers: `.venv/bin/python docs/make_figures.py [DATA_DIR]`.

DATA_DIR defaults to `$SKILLBANK_DATA`, else `../shared/data` beside the checkout. Besides the
figures in docs/figures, it rewrites the numbers the README quotes from a run (docs/readme_numbers.py).
"""

import os
import sys
from pathlib import Path

import skillbank.io as sio
from skillbank.plotting import (
    plot_jerk_profile,
    plot_keypoint_probability,
    plot_segment_grid,
    plot_segments,
)
from skillbank.segmentation import segment

here = Path(__file__).resolve().parent / "figures"
default = os.environ.get("SKILLBANK_DATA") or here.parents[2] / "shared" / "data"
data = Path(sys.argv[1] if len(sys.argv) > 1 else default)
r_demo = sio.read_handwriting_h5(data / "seed/r_shape.h5", index=3)
r = segment(r_demo, window=16, min_size=64, threshold=0.16, combine="product")  # the paper's
plot_jerk_profile(r, here / "r_changepoints.png")
plot_keypoint_probability(r, here / "r_segment_probabilities.png")
plot_segments(r, here / "r_segmented.png", invert_y=True)
r_all = [segment(d) for d in sio.read_handwriting_h5(data / "seed/r_shape.h5")]
plot_segment_grid(r_all, here / "r_all_defaults.png", invert_y=True,
                  titles=[f"demo {i}: cuts {r.keypoints.tolist()}" for i, r in enumerate(r_all)])
demo = sio.read_robot_h5(data / "seed/three_button_pressing_demo.h5")
b = segment(demo)  # the defaults: every stream, each by its kind
plot_segments(b, here / "three_button_segmented.png", dims=3, below=("force", "gripper"), unit="m")
plot_keypoint_probability(b, here / "three_button_probabilities.png")
cuts = (b.keypoint_times - demo.t[0]).round(2).tolist()
print(f"R demo 3: {r.keypoints.tolist()}; three-button: {cuts} s -> {here}")

# issue 14: a three-button press reused on the UR5e: a new button position and goal orientation
import tempfile  # noqa: E402

from skillbank import Constraints  # noqa: E402
from skillbank.core import exp_map  # noqa: E402
from skillbank.pipeline import Library  # noqa: E402
from skillbank.plotting import plot_executable  # noqa: E402
from skillbank.robots import robot_model, to_tool  # noqa: E402

with tempfile.TemporaryDirectory() as tmp, Library(Path(tmp) / "lib.sqlite", create=True) as lib:
    lib.add(demo)  # segmented with the defaults: gripper, three presses, gripper
    prims = sorted(lib.primitives(), key=lambda p: p.start)
    for p in prims[1:4]:  # the three segments that end at a press
        lib.label("press", primitive=p.id)
    ur5e = robot_model("ur5e")
    # the recording's poses are the flange's; the UR5e's tool is the 2F-85's TCP, where the constraints are
    presses = [to_tool(p.demo, ur5e)[0] for p in prims[1:4]]
    first = presses[0]
    task = Constraints(start=first["position"][0], goal=first["position"][-1] + [0.05, -0.03, 0.0],
                       start_orientation=first["orientation"][0],
                       goal_orientation=exp_map([0.0, 0.0, 0.1745], reference=first["orientation"][-1]))
    res = lib.reuse("press", task, method="ja", robot="ur5e", limits={"joint_velocity": 0.5})
    plot_executable(res.trajectory, here / "three_button_reuse_ur5e.png", demos=presses,
                    constraints=task, title="a press reused on the UR5e: the button moved by (5, -3, 0) cm, "
                    "the goal turned 10 deg about the tool axis")
    peak = res.to_dict().get("peak_joint_velocity")
    print(f"reuse on the UR5e: used {res.used}, orientation error {res.orientation_error:.1e} rad, "
          f"peak joint speed {peak:.3f} rad/s, {res.trajectory.t[-1]:.2f} s")

# issue 15: tasks never demonstrated, planned over labelled skills (skillbank.experiments._planning_demo)
import shutil  # noqa: E402

from skillbank.experiments import button_task, rail_task, reach_task  # noqa: E402

with tempfile.TemporaryDirectory() as tmp:
    for name, item in (("buttons", button_task(tmp, data)), ("rail", rail_task(tmp, data)),
                       ("reach", reach_task(tmp))):
        shutil.copyfile(item["files"]["figure"], here / f"planning_{name}.png")
        worst = max(s["end_error"] for s in item["steps"])
        print(f"planning {name}: {item['plan']}, largest end error {worst:.1e} m, "
              f"collision {item['collision']}, clearance {item['clearance']}")

# RAIL clustering, the paper's mode and the default (skillbank.experiments._rail)
from skillbank.experiments import plot_rail_experiment, rail_experiment  # noqa: E402

for mode in ("paper", "default"):
    plot_rail_experiment(rail_experiment(data / "rail", mode=mode), here / f"rail_{mode}.png")

# the numbers the README quotes from a run, taken from one
sys.path.insert(0, str(Path(__file__).resolve().parent))
import readme_numbers  # noqa: E402

numbers = readme_numbers.measure(data)
readme_numbers.README.write_text(readme_numbers.rewrite(readme_numbers.README.read_text(), numbers))
print(f"README numbers: {numbers}")

# issue 24: the whole UR5e past a wall, checked in MuJoCo (the scene of docs/planning.md)
import json  # noqa: E402

from skillbank.planning import plan_task, scene_from_dict  # noqa: E402
from skillbank.plotting import plot_simulation  # noqa: E402
from skillbank.simulation import simulate  # noqa: E402

PRESS = """(:action press
  :parameters (?b - button)
  :precondition (free ?b)
  :effect (and (pressed ?b) (not (free ?b))))"""
text = (here.parent / "planning.md").read_text()
wall = json.loads(text.split("A full scene with a world")[1].split("```json")[1].split("```")[0])
with tempfile.TemporaryDirectory() as tmp, Library(Path(tmp) / "lib.sqlite", create=True) as lib:
    lib.add(demo, assign="none")
    for p in lib.primitives():
        if p.demo["position"][[0, -1], 2].max() < 0.15:  # the presses from one button to the next
            lib.label("press", primitive=p.id)
    lib.describe("press", PRESS)
    scene = scene_from_dict(wall)
    res = plan_task(lib.store, scene, robot="ur5e")
    sim = simulate(res.trajectory, scene, targets=res.targets())
    plot_simulation(sim, scene, here / "simulation_wall.png",
                    title="two presses either side of a wall, replayed in MuJoCo")
    print(f"wall: clearance {res.clearance:.4f} m, facts {sim.facts}, contacts {sim.contacts}")
