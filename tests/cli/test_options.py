"""Argument syntax of the command line: constraints, negative coordinates, segmentation options."""

from __future__ import annotations

import argparse

import pytest

from skillbank.cli._options import (
    add_segmentation_options,
    constraints_from_args,
    join_negative_values,
    segmentation_params,
)
from skillbank.core import Box
from skillbank.segmentation import MultimodalSegmenter


def test_constraints_from_args():
    c = constraints_from_args(start="0,0,0", goal="1, 1, 1", via=["0.5:0.5,0.5,0.9"],
                              obstacle=["sphere:0.5,0.5,0.5,0.1", "BOX:0,0,0,0.2,0.2,0.2"])
    assert c.n_dims == 3 and c.via[0].phase == 0.5 and c.obstacles[0].radius == 0.1
    assert c.obstacles[1].upper.tolist() == [0.2, 0.2, 0.2]
    c2 = constraints_from_args(goal="1,2", via="0.3:1,1", obstacle="box:0,0,1,1", start_velocity="0,1")
    assert c2.n_dims == 2 and c2.start_velocity.tolist() == [0, 1] and isinstance(c2.obstacles[0], Box)
    assert constraints_from_args().is_empty


@pytest.mark.parametrize("kwargs, match", [
    (dict(start="0,0", goal="1,1,1"), r"same number of dimensions.*start has 2, goal has 3"),
    (dict(start="0,x"), r"start: expected a number, got 'x'"),
    (dict(start="0,,1"), r"start: expected comma-separated numbers"),
    (dict(goal=""), r"goal: expected comma-separated numbers"),
    (dict(start="0,inf"), r"start: expected a finite number"),
    (dict(via=["0.5"]), r"via: expected 'PHASE:X,Y\[,Z\]'"),
    (dict(via=["1.5:0,0"]), r"ViaPoint phase: expected a number in \[0.0, 1.0\], got 1.5"),
    (dict(via=["a:0,0"]), r"via phase: expected a number, got 'a'"),
    (dict(obstacle=["cone:0,0,1"]), r"obstacle: expected 'sphere:X,Y\[,Z\],R' or 'box:"),
    (dict(obstacle=["sphere"]), r"obstacle: expected 'sphere"),
    (dict(obstacle=["sphere:1"]), r"a sphere needs a center and a radius, got 1"),
    (dict(obstacle=["sphere:0,0,-1"]), r"sphere radius: expected a number > 0, got -1.0"),
    (dict(obstacle=["box:0,0,1"]), r"a box needs an even number of values.*got 3"),
    (dict(obstacle=["box:1,1,0,0"]), r"expected lower < upper in every coordinate"),
    (dict(obstacle=["sphere:0,nan,1"]), r"obstacle: expected a finite number, got 'nan'"),
])
def test_constraints_from_args_errors(kwargs, match):
    with pytest.raises(ValueError, match=match):
        constraints_from_args(**kwargs)


def test_join_negative_values():
    argv = ["library", "reuse", "db", "--start", "-25,3", "--via", "-0.5:1,2", "--goal", "-1", "--k", "2"]
    assert join_negative_values(argv) == ["library", "reuse", "db", "--start=-25,3", "--via=-0.5:1,2",
                                          "--goal=-1", "--k", "2"]
    # a negative value after an option that takes no coordinates is left to argparse
    assert join_negative_values(["--window", "-3"]) == ["--window", "-3"]


def test_options_left_out_are_the_segmenters_defaults():
    p = argparse.ArgumentParser()
    add_segmentation_options(p)
    assert segmentation_params(p.parse_args([])) == {"random_state": None}
    argv = ["--threshold", "0.3", "--stop-ratio", "none", "--window", "0.1s"]
    given = segmentation_params(p.parse_args(argv))
    assert given == {"threshold": 0.3, "stop_ratio": None, "window": "0.1s", "random_state": None}
    MultimodalSegmenter(**given)  # every key is a segmenter parameter
