"""Streams and columns without information are set aside; the other streams are cut as without them."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import skillbank.io as sio
from skillbank import Demonstration
from skillbank.segmentation import MultimodalSegmenter, segment
from skillbank.segmentation._constant import CONSTANT_ULPS, constant_columns, why_constant
from skillbank.segmentation._events import contact_events


def _with(demo, **streams):
    """``demo`` with ``streams`` added or replaced (``None`` drops one)."""
    out = {k: demo[k] for k in demo.stream_names}
    out.update(streams)
    return Demonstration(demo.t, {k: v for k, v in out.items() if v is not None})


def _two_moves(n=800):
    """Move, rest, move, rest: one rest between movements (at t = 1.5 s)."""
    t = np.linspace(0.0, 4.0, n)
    return Demonstration(t, {"position": np.column_stack([np.minimum(t, 1.0), np.clip(t - 2.0, 0.0, 1.0)])})


@pytest.fixture(scope="module")
def buttons(data_dir):
    return sio.read_robot_h5(data_dir / "seed" / "three_button_pressing_demo.h5")


def test_constant_columns_by_the_precision_they_are_stored_in():
    n = 50
    Y = np.column_stack([np.zeros(n), np.full(n, 0.5), np.linspace(0.0, 1.0, n),
                         np.repeat([0.0, 1.0], n // 2)])
    assert constant_columns(Y).tolist() == [True, True, False, False]
    # a held value a few float64 units off (arithmetic round-off) is constant; a float32 value too
    off = 0.1 + np.arange(n) % 3 * np.spacing(0.1)
    single = np.float32(9.81) + np.arange(n) % 2 * np.spacing(np.float32(9.81))
    assert constant_columns(np.column_stack([off, single.astype(float)])).tolist() == [True, True]
    # ... but not the same change stored as float64 values that are no float32s
    assert not constant_columns((9.81 + np.arange(n) % 2 * 2e-6)[:, None])[0]
    # the bound is CONSTANT_ULPS units of the largest magnitude
    at = np.r_[np.ones(n - 1), 1.0 + CONSTANT_ULPS * np.spacing(1.0)]
    above = np.r_[np.ones(n - 1), 1.0 + 2 * CONSTANT_ULPS * np.spacing(1.0)]
    assert constant_columns(at[:, None])[0] and not constant_columns(above[:, None])[0]
    # values beyond float32's range are float64 (no overflow in the cast)
    assert constant_columns(np.full((n, 1), 1e100)).tolist() == [True]
    assert constant_columns(np.linspace(1e99, 1e100, n)[:, None]).tolist() == [False]


def test_why_constant_says_what_the_stream_holds():
    assert why_constant(np.zeros((10, 3))) == "constant: every value is 0"
    assert why_constant(np.full((10, 1), 0.5)) == "constant: every value is 0.5"
    two = np.column_stack([np.zeros(4), np.ones(4)])
    assert why_constant(two) == "constant: each column holds one value throughout"
    assert why_constant(np.r_[0.5, 0.5 + np.spacing(0.5)][:, None]).startswith("constant to within round-off")


@pytest.mark.parametrize("combine", ["evidence", "product"])
@pytest.mark.parametrize(("name", "value"), [("force", 0.0), ("force", 0.5), ("torque", -3.0),
                                             ("joints", 0.5), ("gripper", 1.0), ("position_2", 0.0)])
def test_a_constant_stream_changes_no_cut_and_is_reported(combine, name, value):
    demo = _two_moves()
    alone = segment(demo, combine=combine)
    seg = MultimodalSegmenter(combine=combine).fit(_with(demo, **{name: np.full((demo.n_steps, 3), value)}))
    assert seg.result_.keypoints.tolist() == alone.keypoints.tolist() != []
    assert seg.set_aside_ == {name: f"constant: every value is {value:g}"} == seg.result_.set_aside
    assert seg.result_.streams[name].changepoints.size == 0
    doc = seg.result_.to_dict()
    assert doc["set_aside"] == seg.set_aside_ and doc["changepoints"][name] == []


def test_three_button_with_its_torque_zeroed_is_cut_as_without_torque(buttons):
    # was: "the computation overflowed or became undefined"
    zeroed = MultimodalSegmenter().fit(_with(buttons, torque=np.zeros((buttons.n_steps, 3))))
    without = segment(buttons.select(["joints", "position", "orientation", "force", "gripper"]))
    assert zeroed.result_.keypoints.tolist() == without.keypoints.tolist()
    assert zeroed.set_aside_ == {"torque": "constant: every value is 0"}
    # force at 0.5 N throughout, torque at zero: as with neither
    n = buttons.n_steps
    both = segment(_with(buttons, torque=np.zeros((n, 3)), force=np.full((n, 3), 0.5)))
    neither = segment(buttons.select(["joints", "position", "orientation", "gripper"]))
    assert both.keypoints.tolist() == neither.keypoints.tolist()
    assert set(both.set_aside) == {"force", "torque"}


def test_a_constant_column_is_left_out_of_its_stream(buttons):
    torque = buttons["torque"].copy()
    torque[:, 0] = 0.0
    seg = MultimodalSegmenter().fit(_with(buttons, torque=torque))
    two = segment(_with(buttons, torque=torque[:, 1:]))
    assert seg.result_.keypoints.tolist() == two.keypoints.tolist()
    assert seg.constant_columns_ == {"torque": [0]} and seg.set_aside_ == {}
    # a motion stream too: a held coordinate of 0.5 is no round-off of the moving ones
    demo = _two_moves()
    held = np.column_stack([demo["position"], np.full(demo.n_steps, 0.5)])
    assert segment(_with(demo, position=held)).keypoints.tolist() == segment(demo).keypoints.tolist()


def test_every_stream_constant_is_one_segment():
    t = np.linspace(0.0, 1.0, 300)
    still = Demonstration(t, {"position": np.zeros((300, 3)), "force": np.ones((300, 3))})
    seg = MultimodalSegmenter().fit(still)
    assert seg.result_.n_segments == 1 and sorted(seg.set_aside_) == ["force", "position"]
    assert np.all(seg.result_.probability == 0.0)
    product = segment(Demonstration(t, {"position": np.zeros((300, 3))}), combine="product", mode="sampling",
                      random_state=0)
    assert product.n_segments == 1 and product.set_aside == {"position": "constant: every value is 0"}


def test_a_step_of_tiny_values_is_a_contact_step():
    # the variance floor of values near 1e-300 underflowed: 0 / 0
    f = np.r_[np.zeros(300), np.full(300, 1e-300)][:, None]
    at, conf = contact_events(f, window=30)
    big_at, big_conf = contact_events(f * 1e300, window=30)
    assert at.tolist() == big_at.tolist() == [300] and conf.tolist() == big_conf.tolist()


def test_contact_events_are_the_same_in_any_unit(buttons):
    # effect sizes have no unit (by a power of two the rescaling is even exact)
    at, conf = contact_events(buttons["force"], window=164)
    for scale in (2.0**-600, 1e-3, 1e6):
        a, c = contact_events(buttons["force"] * scale, window=164)
        assert a.tolist() == at.tolist()
        np.testing.assert_allclose(c, conf, rtol=1e-12)


@settings(max_examples=25, deadline=None)
@given(st.floats(-1e6, 1e6, allow_nan=False), st.integers(1, 4),
       st.sampled_from(["force", "torque", "joints", "gripper", "extra"]),
       st.sampled_from(["evidence", "product"]))
def test_property_a_constant_stream_never_moves_a_cut(value, width, name, combine):
    demo = _two_moves(600)
    base = segment(demo, combine=combine).keypoints.tolist()
    with_it = segment(_with(demo, **{name: np.full((demo.n_steps, width), value)}), combine=combine)
    assert with_it.keypoints.tolist() == base and name in with_it.set_aside
