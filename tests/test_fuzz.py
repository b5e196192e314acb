"""Fuzz of the public API at the edges of float64 (issue 12, items 4 and 6).

Every call gets trajectories, time stamps, constraints and features drawn over
shapes, magnitudes from 1e-300 to 1e300, offsets up to 1e302, NaN, inf and
complex values. The only acceptable outcomes are a ``ValueError`` /
``TypeError`` whose one-line message starts with the argument (or the step)
it is about, or a finite result; no warning may escape but the
representations' own ``UserWarning`` that an obstacle post-edit failed.
"""

from __future__ import annotations

import os
import re
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from skillbank.clustering import DTWFeatures, ElasticClustering, HeadingFeatures, TrajectoryFeatures
from skillbank.core import Constraints, Demonstration, Sphere
from skillbank.editing import lte
from skillbank.metrics import dtw_distance, frechet_distance
from skillbank.representations import REPRESENTATIONS
from skillbank.segmentation import segment

# Mostly inside the validator's bound (1e100), so that the solvers themselves are exercised.
MAGNITUDES = (1e-300, 1e-150, 1e-8, 1.0, 1.0, 1e8, 1e50, 1e100, 1e150, 1e300)
OFFSETS = (0.0, 0.0, 1.0, 1.7e9, -1e99, 1e150, 1e302)
SPECIAL = (None,) * 8 + (np.nan, np.inf, -np.inf, "complex")
# 40 examples per target keeps the file under ~10 s; SKILLBANK_FUZZ_EXAMPLES=2000 fuzzes deeper.
FUZZ = settings(max_examples=int(os.environ.get("SKILLBANK_FUZZ_EXAMPLES", "40")), deadline=None,
                suppress_health_check=[HealthCheck.too_slow])

# What an error message may start with: an argument (with an index) or a computation step.
_ARGUMENTS = (
    r"Y|t|P|Q|X|goal|start|constraints|demos|demo|streams\['position'\]|sphere center|sphere radius|weight|"
    r"X\[\d+\]|demos\[\d+\]|n_components|n_steps|n_clusters|primitives"
)
_STEPS = (r"lte.*|\w+\.(fit|reproduce|fit_transform|transform)( \(\w+\))?|"
          r"frechet_distance|dtw_distance|dtw_many")
_HEAD = re.compile(rf"^({_ARGUMENTS}|{_STEPS}): ")


@st.composite
def arrays(draw, n=None, d=None, *, min_n=1, max_n=12):
    """A random walk of ``n`` samples in ``d`` dimensions at a drawn scale and offset, maybe spoiled."""
    n = draw(st.integers(min_n, max_n)) if n is None else n
    d = draw(st.integers(1, 3)) if d is None else d
    steps = np.array(draw(st.lists(st.floats(-1.0, 1.0), min_size=n * d, max_size=n * d))).reshape(n, d)
    Y = draw(st.sampled_from(OFFSETS)) + draw(st.sampled_from(MAGNITUDES)) * np.cumsum(steps, axis=0)
    special = draw(st.sampled_from(SPECIAL))
    if special is not None:
        i, j = draw(st.integers(0, n - 1)), draw(st.integers(0, d - 1))
        if special == "complex":
            Y = Y.astype(complex)
            Y[i, j] += 1j
        else:
            Y[i, j] = special
    return Y


@st.composite
def times(draw, n):
    """Time stamps: an offset plus scaled cumulative steps, now and then one repeated or backwards."""
    steps = np.array(draw(st.lists(st.floats(0.01, 1.0), min_size=n, max_size=n)))
    if n > 1 and draw(st.integers(0, 5)) == 0:
        steps[draw(st.integers(1, n - 1))] = draw(st.sampled_from([0.0, -0.5]))
    return draw(st.sampled_from(OFFSETS)) + draw(st.sampled_from(MAGNITUDES)) * np.cumsum(steps)


@st.composite
def tasks(draw, n_dims):
    """A drawn goal and a drawn sphere, either possibly at the edges too (built inside the call)."""
    goal = draw(st.none() | arrays(1, n_dims))
    sphere = draw(st.none() | st.tuples(arrays(1, n_dims), st.sampled_from(MAGNITUDES)))

    def build():
        obstacles = [] if sphere is None else [Sphere(sphere[0][0], sphere[1])]
        return Constraints(goal=None if goal is None else goal[0], obstacles=obstacles)

    return build


def _expected_warning(w) -> bool:
    return w.category is UserWarning and "obstacle editing did not succeed" in str(w.message)


def _outcome(call, results):
    """Run ``call``; check its error message or that ``results(out)`` are all finite; no warnings leak."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            out = call()
        except (ValueError, TypeError) as exc:
            message = str(exc)
            assert "\n" not in message and len(message) < 600, message
            assert _HEAD.match(message), f"message does not name an argument or step: {message!r}"
        else:
            for value in results(out):
                assert np.all(np.isfinite(np.asarray(value, dtype=float))), f"non-finite result {value!r}"
    leaked = [f"{w.category.__name__}: {w.message}" for w in caught if not _expected_warning(w)]
    assert not leaked


@FUZZ
@given(st.data())
def test_segment(data):
    Y = data.draw(arrays(min_n=2, max_n=80))
    t = data.draw(times(Y.shape[0]))
    _outcome(lambda: segment(Demonstration(t, {"position": Y})), lambda r: [r.n_segments])


@FUZZ
@given(st.data())
def test_lte(data):
    Y = data.draw(arrays())
    t = data.draw(st.none() | times(Y.shape[0]))
    task = data.draw(tasks(Y.shape[1]))
    hard, weight = data.draw(st.booleans()), data.draw(st.sampled_from(MAGNITUDES))

    def call():
        return lte(Y, task(), t=t, hard=hard, weight=weight)

    _outcome(call, lambda r: [r.Y, r.constraint_error, r.velocity_error])


@pytest.mark.parametrize("method", list(REPRESENTATIONS))
@FUZZ
@given(data=st.data())
def test_representation(method, data):
    cls = REPRESENTATIONS[method]
    d = data.draw(st.integers(1, 3))
    k = 1 if cls.single_demo else data.draw(st.integers(1, 3))
    demos = []
    for _ in range(k):
        Y = data.draw(arrays(d=d, min_n=cls.min_samples, max_n=16))
        t = data.draw(st.none() | times(Y.shape[0]))
        demos.append((Y, t))
    task = data.draw(tasks(d))

    def call():
        inputs = [Y if t is None else Demonstration(t, {"position": Y}) for Y, t in demos]
        return cls().fit(inputs).reproduce(task())

    _outcome(call, lambda out: [out["position"], out.t])


@FUZZ
@given(st.data())
def test_elastic_clustering(data):
    X = data.draw(arrays(min_n=1, max_n=20))

    def call():
        return ElasticClustering(random_state=0).fit(X)

    _outcome(call, lambda m: [m.cluster_centers_, m.energy_])


@pytest.mark.parametrize("featuriser", [HeadingFeatures, TrajectoryFeatures, DTWFeatures],
                         ids=lambda c: c.__name__)
@FUZZ
@given(data=st.data())
def test_featurisers(featuriser, data):
    d = data.draw(st.integers(1, 3))
    trajs = data.draw(st.lists(arrays(d=d, min_n=1, max_n=10), min_size=1, max_size=5))
    kwargs = {} if featuriser is DTWFeatures else {"n_components": data.draw(st.sampled_from([None, 1, 2]))}
    _outcome(lambda: featuriser(**kwargs).fit_transform(trajs), lambda F: [F])


@pytest.mark.parametrize("distance", [frechet_distance, dtw_distance], ids=lambda f: f.__name__)
@FUZZ
@given(data=st.data())
def test_distances(distance, data):
    P = data.draw(arrays(max_n=10))
    Q = data.draw(arrays(d=P.shape[1], max_n=10))
    _outcome(lambda: distance(P, Q), lambda value: [value])


# Python numbers of any size (issue 23, item 8): ints beyond float64 overflowed in the cast.
NUMBERS = st.integers(-10 ** 500, 10 ** 500) | st.sampled_from([10 ** 101, -10 ** 400, 2 ** 63]) | st.floats()
_GEOMETRY_HEAD = re.compile(r"^(goal|start|start_velocity|via\[0\]|sphere center|sphere radius|box lower|"
                            r"box upper|box|obstacle( '[^']*')?|ViaPoint index|via position|constraints): ")


@FUZZ
@given(st.lists(NUMBERS, min_size=1, max_size=3), NUMBERS, st.integers(-10 ** 30, 10 ** 30),
       st.sampled_from(["goal", "start_velocity", "via", "sphere", "box", "spec", "index"]))
def test_geometry_from_python_numbers_of_any_size(point, number, index, kind):
    from skillbank.core import Box, ViaPoint, parse_obstacle  # the geometry constructors fuzzed here

    calls = {"goal": lambda: Constraints(goal=point, start=[0.0] * len(point)),
             "start_velocity": lambda: Constraints(start_velocity=point),
             "via": lambda: Constraints(via=[(0.5, point)]),
             "sphere": lambda: Sphere(point, number),
             "box": lambda: Box(point, [number] * len(point)),
             "spec": lambda: parse_obstacle("sphere:" + ",".join(map(str, point)) + f",{number}"),
             "index": lambda: ViaPoint(point, index=index).sample(10)}
    try:
        calls[kind]()
    except ValueError as exc:
        message = str(exc)
        assert "\n" not in message and len(message) < 300, message
        assert _GEOMETRY_HEAD.match(message), message
