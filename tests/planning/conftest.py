"""Libraries with a labelled, described 'press' skill: synthetic (no data) and the three-button demo."""

from __future__ import annotations

import json

import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.pipeline import Library

PRESS = """; press a free button
(:action press
  :parameters (?b - button)
  :precondition (free ?b)
  :effect (and (pressed ?b) (not (free ?b))))
"""
DOWN = [1.0, 0.0, 0.0, 0.0]  # the tool pointing down


def press_motion(travel, lift=0.05, n=60, duration=2.0) -> Demonstration:
    """Lift, move by ``travel`` and press down: a press primitive that starts and ends at rest."""
    s = np.linspace(0.0, 1.0, n)
    ease = 0.5 - 0.5 * np.cos(np.pi * s)
    P = np.outer(ease, travel) + np.c_[0 * s, 0 * s, lift * np.sin(np.pi * s)]
    Q = np.tile(DOWN, (n, 1))
    return Demonstration(s * duration, {"position": P, "orientation": Q, "gripper": np.ones((n, 1))})


@pytest.fixture
def synthetic_db(new_library):
    """Where :func:`synthetic_library` is (a file or a URL: the tests run on every store backend)."""
    return new_library("synthetic")


@pytest.fixture
def synthetic_library(synthetic_db):
    """Three press primitives labelled 'press' (no description yet)."""
    lib = Library(synthetic_db)
    for travel in ([0.2, 0.0, 0.0], [0.0, 0.2, 0.0], [0.15, 0.1, 0.0]):
        lib.add(press_motion(np.array(travel)), segment=False, label="press")
    yield lib
    lib.close()


@pytest.fixture
def described_library(synthetic_library):
    synthetic_library.describe("press", PRESS)
    return synthetic_library


def button_scene(positions, *, goal, obstacles=(), start=(0.0, 0.0, 0.0), orientation=DOWN, **extra) -> dict:
    names = [f"b{k}" for k in range(1, len(positions) + 1)]
    doc = {"objects": {n: {"type": "button", "position": list(p), "orientation": list(orientation)}
                       for n, p in zip(names, positions, strict=True)},
           "obstacles": obstacles if isinstance(obstacles, dict) else list(obstacles),
           "init": [f"(free {n})" for n in names],
           "goal": [f"(pressed {g})" for g in goal],
           "start": {"position": list(start), "orientation": list(orientation)}}
    doc.update(extra)
    return doc


def write_scene(folder, doc, name="scene.json"):
    path = folder / name
    path.write_text(json.dumps(doc))
    return path


@pytest.fixture(scope="module")
def button_library(tmp_path_factory, data_dir):
    """The three-button demonstration, segmented; its two button-to-button presses labelled 'press'."""
    from skillbank.io import load

    lib = Library(tmp_path_factory.mktemp("buttons") / "buttons.db")
    lib.add(load(data_dir / "seed" / "three_button_pressing_demo.h5"), segment=True, assign="none")
    # the presses from one button to the next start and end down at a button (z < 0.15 m)
    presses = [p for p in lib.primitives() if p.demo["position"][[0, -1], 2].max() < 0.15]
    assert len(presses) == 2
    for p in presses:
        lib.label("press", primitive=p.id)
    lib.describe("press", PRESS)
    yield lib
    lib.close()


#: Two buttons, both to press, from the origin (the synthetic skill's reach).
BUTTONS_DOC = button_scene([[0.2, 0.0, 0.0], [0.2, 0.2, 0.0]], goal=["b1", "b2"])
