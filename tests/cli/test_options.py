"""Argument syntax of the command line: constraints, negative coordinates, segmentation options."""

from __future__ import annotations

import argparse
import re

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from skillbank.cli._options import (
    add_segmentation_options,
    constraints_from_args,
    join_negative_values,
    margin,
    segmentation_params,
    size,
)
from skillbank.core import Box
from skillbank.segmentation import MultimodalSegmenter
from skillbank.segmentation._segmenter import to_samples


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


def test_sizes_in_samples_and_seconds():
    assert (size("64"), size(" 0.1s "), size("1.s"), size("auto")) == (64, "0.1s", "1.0s", "auto")
    assert (margin("0"), margin("0s"), margin("-0s"), margin("0.0e3s"), margin("5")) == (0, 0, 0, 0, 5)
    t = np.linspace(0.0, 1.0, 101)  # 0.01 s period
    assert to_samples(size("1.s"), t, name="window") == 100
    assert to_samples(size("2.5e-1s"), t, name="window") == 25


@pytest.mark.parametrize("value", ["0", "0s", "-0s", "0.0s", "-1", "-0.1s", "nans", "infs", "1e400s", "s",
                                   "1.5", "ten", "10 samples", ""])
def test_size_rejects_what_is_not_a_positive_size(value):
    with pytest.raises(argparse.ArgumentTypeError,
                       match=rf"expected an integer number of samples > 0 or seconds > 0 like '0.1s', "
                             rf"got {re.escape(repr(value.strip()))}"):
        size(value)


@pytest.mark.parametrize("value", ["-1", "-0.1s", "nans", "infs", "1.5", "x"])
def test_margin_rejects_negative_and_non_numbers(value):
    with pytest.raises(argparse.ArgumentTypeError, match=r"samples >= 0 or seconds >= 0"):
        margin(value)


@given(st.floats(min_value=1e-6, max_value=1e6, allow_nan=False))
def test_positive_seconds_reach_the_segmenter_unchanged(seconds):
    text = size(f"{seconds}s")
    t = np.linspace(0.0, 1.0, 11)
    # the segmenter reads what the command line wrote, to the same number of samples
    assert to_samples(text, t, name="window") == max(1, round(seconds / np.median(np.diff(t))))


@given(st.integers(min_value=-10**6, max_value=10**6))
def test_sample_counts(n):
    if n > 0:
        assert size(str(n)) == n == margin(str(n))
    elif n == 0:
        assert margin("0") == 0
    else:
        with pytest.raises(argparse.ArgumentTypeError):
            margin(str(n))
    if n <= 0:
        with pytest.raises(argparse.ArgumentTypeError):
            size(str(n))
