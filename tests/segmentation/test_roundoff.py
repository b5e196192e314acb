"""The values' round-off, the strided jerk, and which streams the segmenter differentiates over a stride."""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import skillbank.io as sio
from skillbank import Demonstration
from skillbank.experiments import synthetic_multistream
from skillbank.segmentation import jerk, jerk_profile, segment
from skillbank.segmentation._profile import normalize_profile
from skillbank.segmentation._roundoff import (
    empirical_level,
    resolution_floor,
    roundoff_level,
    value_resolution,
)


def _digits(x, p):
    return np.array([float(f"{v:.{p}g}") for v in np.ravel(x)]).reshape(np.shape(x))


# ------------------------------------------------------------------ the values' grid


@pytest.mark.parametrize("p", [6, 8, 10, 12, 15])
def test_resolution_of_decimal_digits(p):
    x = _digits(1.0 + np.sqrt(np.linspace(0.0, 8.0, 500)), p)  # largest value 3.83
    assert value_resolution(x) == pytest.approx(0.5 * 10.0 ** (1 - p))


def test_resolution_of_float32_integers_and_full_precision():
    x = np.sqrt(np.linspace(1.0, 3.9, 500))  # largest 1.97, in [1, 2)
    assert value_resolution(x.astype(np.float32).astype(float)) == 2.0**-24  # 24 bits: step 2^-23
    assert value_resolution(x) == np.spacing(x.max()) / 2  # every one of the 53 bits is used
    assert value_resolution(np.arange(0.0, 4096.0)) == 0.5  # 12 bits below 4096
    assert value_resolution(-np.arange(0.0, 4096.0)) == 0.5
    assert value_resolution(np.zeros(10)) == 0.0


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(1e-6, 1e6) | st.floats(-1e6, -1e-6), min_size=1, max_size=200),
       st.integers(3, 15))
def test_property_resolution_bounds_the_rounding(values, p):
    # whatever was written with p digits is within the resolution of what was written (a tie
    # rounds by exactly half a step, give or take the double nearest the decimal)
    x = np.array(values)
    written = _digits(x, p)
    # (the double nearest a decimal tie is up to one unit in the last place beyond half a step)
    assert np.abs(written - x).max() <= value_resolution(written) + np.spacing(np.abs(x)).max()


def test_empirical_level_sees_rounding_and_ignores_held_values():
    # a fine line on a grid of 1e-6: uniform errors, half a step is 5e-7
    t = np.linspace(0.0, 1.0, 20_000)
    x = np.round(np.sin(3 * t) / 1e-6) * 1e-6
    assert empirical_level(x[:, None])[0] == pytest.approx(5e-7, rel=0.15)
    held = np.repeat([0.0, 1.0, 0.0], 100)
    assert empirical_level(held).tolist() == [0.0]
    assert roundoff_level(held).tolist() == [0.5]  # on a grid of step 1 ...
    assert roundoff_level(held, empirical=True).tolist() == [2.0**-33]  # ... but exact, to within the floor


# ------------------------------------------------------------------ the floor


def test_floor_is_half_a_32_bit_step_of_the_range():
    assert resolution_floor(np.linspace(-2.0**31, 2.0**31, 7)).tolist() == [0.5]
    t = np.linspace(5.0, 105.0, 1001)  # a clock: its range is the duration, wherever it starts
    assert resolution_floor(t).tolist() == [100.0 * 2.0**-33]
    assert resolution_floor(np.full((4, 2), 3.0)).tolist() == [0.0, 0.0]
    # full-precision values: the floor is the level (float64's own half step is 1e-16 of them)
    x = np.sin(np.linspace(0.0, 3.0, 500))
    assert roundoff_level(x).tolist() == resolution_floor(x).tolist()
    # values whose grid is coarser than the floor keep their grid
    assert roundoff_level(_digits(x, 8))[0] == pytest.approx(5e-9)


def test_original_and_12_digit_copy_share_one_level_but_not_an_8_digit_one():
    i = np.arange(100_000)
    t = np.cumsum(1e-3 * (1.0 + 0.2 * np.sin(i / 5e3)))  # an uneven clock (a regular one is a short decimal)
    Y = np.column_stack([np.sin(t / 7.0), 0.5 * np.cos(t / 3.0) + 0.2])
    for x in (Y, t):
        assert roundoff_level(_digits(x, 12)) == pytest.approx(roundoff_level(x), rel=1e-9)
        assert np.all(roundoff_level(_digits(x, 8)) > 2 * roundoff_level(x))


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-1e3, 1e3), min_size=2, max_size=200))
def test_property_a_12_digit_copy_has_the_originals_level(values):
    # the floor, half a 32-bit step of the range (1.2e-10 of it), is above 12 digits' half step
    # (at most 5e-12 of the largest value) unless the values sit far from zero next to their range
    x = np.array(values)
    assume(np.ptp(x) > 0 and np.abs(x).max() <= np.ptp(x))
    copy = _digits(x, 12)
    # The claim is about an original whose values show their precision and a copy that shows its
    # 12 digits. Values that all happen to be short (test_values_that_look_short_are_read_as_short)
    # are the same numbers as a short file's, and no estimator can tell them apart.
    assume(value_resolution(x) <= resolution_floor(x)[0])
    assume(value_resolution(copy) <= 0.5 * 10.0 ** (np.floor(np.log10(np.abs(copy).max())) - 11))
    level = roundoff_level(x)
    assert level[0] >= resolution_floor(x)[0]
    assert roundoff_level(copy) == pytest.approx(level, rel=1e-9)


@pytest.mark.parametrize("values", [[0.0, 1.9999999999998863], [3.0, 2.220446049250313e-16]])
def test_values_that_look_short_are_read_as_short(values):
    # Hypothesis's counter-examples to the property above, before it named its premise. Written with
    # 12 digits, 1.9999999999998863 is "2": the file [0, 2] is the same bytes whether it was written
    # with 12 digits or with one, its values lie on a grid of one significant bit and nothing in
    # them says otherwise, so its round-off is half that grid's step. Likewise the "original"
    # [3, 2^-52] uses two significant bits, while its 12-digit copy writes 2^-52 with 12 digits.
    # With a recording's hundreds of values, every one being short when the file is not has no
    # chance; one value that shows its digits is enough.
    x = np.array(values)
    copy = _digits(x, 12)
    coarse = [a for a in (x, copy) if value_resolution(a) > resolution_floor(a)[0]]
    assert len(coarse) == 1
    assert roundoff_level(coarse[0])[0] == value_resolution(coarse[0]) >= 0.5
    longer = np.append(x, 1.2345678901234567)
    assert roundoff_level(_digits(longer, 12)) == pytest.approx(roundoff_level(longer), rel=1e-9)


# ------------------------------------------------------------------ strided jerk


def test_strided_jerk_is_exact_for_cubics():
    t = np.linspace(0.0, 2.0, 400)
    for step in (1, 4, 16):
        inner = slice(3 * step, -3 * step)
        np.testing.assert_allclose(jerk(t, t[:, None] ** 3, step=step)[inner], 6.0, rtol=1e-6)


def test_stride_divides_round_off_by_its_cube():
    # 10 digits leave ~5e-11 on each value: ~0.05 of jerk at 1 ms, 1/64 of that over 4 samples
    t = np.arange(20_000) * 1e-3
    Y = np.sin(t)[:, None]
    written = _digits(Y, 10)
    err1 = np.median(np.abs(jerk(t, written) - jerk(t, Y))[20:-20])
    err4 = np.median(np.abs(jerk(t, written, step=4) - jerk(t, Y, step=4))[20:-20])
    assert err1 > 0.005 and 30 < err1 / err4 < 130


def test_strided_jerk_on_an_uneven_clock():
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.8, 1.2, 2000)) * 0.01
    err = np.abs(jerk(t, np.sin(t)[:, None], step=3)[20:-20, 0] + np.cos(t)[20:-20])
    assert err.max() < 0.05


@pytest.mark.parametrize("step", [0, -2, 1.5, "2"])
def test_bad_step(step):
    with pytest.raises(ValueError, match=r"step: expected an integer > 0, got"):
        jerk(np.arange(10.0), np.zeros(10), step=step)


def test_ripple_leaves_out_twins_but_not_plateau_pieces():
    twin = np.array([0.0, 5.0, 4.998, 4.999, 0.0, 2.0, 0.0, 1.0, 0.0])
    assert normalize_profile(twin).max() == pytest.approx(5.0 / 3.4995)  # the twin counts
    assert normalize_profile(twin, ripple=0.01).max() == pytest.approx(2.5)  # it does not
    level = np.array([0.0, 5.0, 4.0, 4.0, 0.0, 2.0, 0.0, 1.0, 0.0])  # a shoulder: prominence 0
    assert normalize_profile(level, ripple=0.01).max() == normalize_profile(level).max()


# ------------------------------------------------------------------ which streams are strided


def test_noisy_copy_is_strided_and_public_building_blocks_agree():
    n = 100_000
    t = np.arange(n) * 1e-3
    s = np.clip(np.abs(((t / 25.0) % 2.0) - 1.0) * 1.6 - 0.3, 0.0, 1.0)
    Y = np.column_stack([10 * s**3 - 15 * s**4 + 6 * s**5, np.sin(t / 9.0)])
    full = segment(Demonstration(t, {"position": Y}))
    copy = segment(Demonstration(t, {"position": _digits(Y, 8)}))
    # at 1 kHz even the floor (a 32-bit step of each range) swamps this slow motion's jerk; 8 digits more
    stream = copy.streams["position"]
    assert stream.jerk_step > full.streams["position"].jerk_step > 1
    p = stream.params
    raw, profile = jerk_profile(t, _digits(Y, 8), window=p["window"], grace=p["grace"])
    np.testing.assert_array_equal(raw, stream.jerk)
    np.testing.assert_array_equal(profile, stream.profile)


def test_held_exact_streams_stay_at_single_samples():
    # the gripper (0/1) and force (0/-5) lie on coarse grids but are exact
    result = segment(synthetic_multistream())
    assert {k: s.jerk_step for k, s in result.streams.items()} == {"position": 1, "gripper": 1, "force": 1}


def test_real_data_stay_at_single_samples(data_dir):
    demos = sio.read_handwriting_h5(data_dir / "seed" / "r_shape.h5", group="normalized")
    for demo in demos:
        assert segment(demo).streams["position"].jerk_step == 1
    buttons = sio.read_robot_h5(data_dir / "seed" / "three_button_pressing_demo.h5")
    # two joints (the elbow, third in chain order, and wrist 3) are stored as float32: their
    # round-off reaches 0.4 % of the profile, under the 1 % share
    levels = roundoff_level(buttons["joints"])
    assert levels[2] == 2.0**-24 and levels[5] == 2.0**-23
    result = segment(buttons, ["joints", "position", "force", "gripper"])
    assert all(s.jerk_step == 1 for s in result.streams.values())
