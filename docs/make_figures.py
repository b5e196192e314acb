"""Regenerate the README figures: `.venv/bin/python docs/make_figures.py [DATA_DIR]`."""

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
default = os.environ.get("SKILLBANK_DATA", here.parents[2] / "shared/data")
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
plot_segments(b, here / "three_button_segmented.png", dims=3, below=("force", "gripper"))
plot_keypoint_probability(b, here / "three_button_probabilities.png")
cuts = (b.keypoint_times - demo.t[0]).round(2).tolist()
print(f"R demo 3: {r.keypoints.tolist()}; three-button: {cuts} s -> {here}")
