import numpy as np
import pytest

from skillbank import Demonstration


def _demo(n=10):
    t = np.linspace(0.0, 0.9, n)
    return Demonstration(
        t, {"position": np.column_stack([t, 2 * t]), "gripper": t}, {"label": "reach"}
    )


def test_streams_are_2d_and_aligned():
    demo = _demo()
    assert demo.n_steps == 10
    assert demo["gripper"].shape == (10, 1)
    assert demo.stream_names == ["position", "gripper"]
    assert "position" in demo and len(demo) == 10


def test_slicing_returns_a_demonstration_with_its_range():
    demo = _demo()
    part = demo[2:6]
    assert isinstance(part, Demonstration)
    assert part.n_steps == 4
    np.testing.assert_array_equal(part.t, demo.t[2:6])
    np.testing.assert_array_equal(part["position"], demo["position"][2:6])
    assert part.metadata["range"] == [2, 6]
    assert part.metadata["label"] == "reach"
    # nested slices keep indices relative to the original demonstration
    assert part[1:3].metadata["range"] == [3, 5]


@pytest.mark.parametrize(
    ("t", "streams", "match"),
    [
        ([0.0, 1.0, 0.5], {"p": np.zeros(3)}, r"t: expected strictly increasing time"),
        ([0.0, np.nan], {"p": np.zeros(2)}, r"t: expected finite values"),
        ([0.0, 1.0], {"p": np.zeros(3)}, r"streams\['p'\]: expected 2 samples to match t, got 3"),
        ([0.0, 1.0], {"p": [0.0, np.inf]}, r"streams\['p'\]: expected finite values"),
        ([0.0, 1.0], {"p": np.zeros((2, 1, 1))}, r"streams\['p'\]: expected a 1-D or 2-D array"),
        ([0.0, 1.0], {"": np.zeros(2)}, r"streams: expected non-empty string names"),
        ([0.0, 1.0], [1, 2], r"streams: expected a mapping"),
    ],
)
def test_invalid_demonstrations(t, streams, match):
    with pytest.raises(ValueError, match=match):
        Demonstration(t, streams)


def test_empty_slice_is_rejected():
    with pytest.raises(ValueError, match=r"slice: expected a non-empty sample range"):
        _demo().slice(5, 5)


def test_unknown_stream_lookup():
    with pytest.raises(KeyError, match="no stream 'force'"):
        _demo()["force"]
    with pytest.raises(ValueError, match=r"streams: expected names among"):
        _demo().select(["force"])


def test_from_clocks_interpolates_onto_reference_clock():
    t_ref = np.linspace(0.0, 1.0, 11)
    t_other = np.linspace(0.05, 1.05, 7)
    demo = Demonstration.from_clocks(
        {"joints": (t_ref, np.column_stack([t_ref, -t_ref])), "force": (t_other, 3 * t_other)},
        reference="joints",
    )
    np.testing.assert_array_equal(demo.t, t_ref)
    inside = (t_ref >= 0.05) & (t_ref <= 1.05)
    np.testing.assert_allclose(demo["force"][inside, 0], 3 * t_ref[inside])
    # held at the edge before the other clock starts
    assert demo["force"][0, 0] == pytest.approx(0.15)


def test_from_clocks_rejects_bad_clock():
    with pytest.raises(ValueError, match=r"clocked\['f'\] time: expected strictly increasing"):
        Demonstration.from_clocks({"f": ([0.0, 0.0], [1.0, 2.0])})
    with pytest.raises(ValueError, match=r"reference: expected one of \['f'\], got 'g'"):
        Demonstration.from_clocks({"f": ([0.0, 1.0], [1.0, 2.0])}, reference="g")


def test_from_array_default_clock():
    demo = Demonstration.from_array(np.ones((4, 3)), dt=0.5)
    np.testing.assert_array_equal(demo.t, [0.0, 0.5, 1.0, 1.5])
    assert demo.stream_names == ["position"]


def test_orientation_stream_is_unit_and_continuous():
    t = np.linspace(0.0, 1.0, 4)
    half = np.sqrt(0.5)
    q = np.array([[0, 0, 0, 1.0], [0, 0, -half, -half], [0, 0, 1.0, 0], [0, 0, 0.6, 0.8005]])
    demo = Demonstration(t, {"orientation": q})
    Q = demo["orientation"]
    np.testing.assert_allclose(np.linalg.norm(Q, axis=1), 1.0)
    # the second sample is -q of a quarter turn: flipped so that no two neighbours are a half sphere apart
    assert np.all(np.einsum("ij,ij->i", Q[1:], Q[:-1]) >= 0)
    np.testing.assert_allclose(Q[1], [0, 0, half, half])


@pytest.mark.parametrize(
    ("q", "match"),
    [
        (np.tile([0, 0, 0, 2.0], (3, 1)),
         r"streams\['orientation'\]: expected unit quaternions \(norm within 0.01 of 1\), got norm 2 at "
         r"sample 0 \(3 such samples"),
        (np.zeros((3, 4)),
         r"streams\['orientation'\]: expected unit quaternions .*got zero norm at sample 0"),
        (np.zeros((3, 3)), r"streams\['orientation'\]: expected quaternions of 4 components \(x, y, z, w\), "
                           r"got shape \(3, 3\)"),
    ],
)
def test_orientation_stream_errors(q, match):
    with pytest.raises(ValueError, match=match):
        Demonstration(np.arange(3.0), {"orientation": q})


def test_a_unit_orientation_keeps_its_bits():
    # checked again (a stored stream read back), the numbers do not change: content hashes stay equal
    rng = np.random.default_rng(0)
    q = rng.normal(size=(50, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True) / rng.uniform(0.995, 1.005, (50, 1))  # a little off unit
    once = Demonstration(np.arange(50.0), {"orientation": q})["orientation"]
    twice = Demonstration(np.arange(50.0), {"orientation": once})["orientation"]
    assert np.array_equal(once, twice)
