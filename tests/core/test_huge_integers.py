"""Python integers beyond float64 (issue 23, item 8): one ValueError naming the argument, never OverflowError.

``float(10 ** 400)`` raises OverflowError, and so did every constructor that cast such an int: the
validator now reports it (with its number of digits and index) before the cast, and ids are bounded
to the signed 64-bit range that every store holds.
"""

from __future__ import annotations

import numpy as np
import pytest

from skillbank.core import Box, Constraints, Demonstration, Sphere, ViaPoint, parse_obstacle
from skillbank.core._validation import check_array, check_id, check_positive

HUGE = 10 ** 400
_BOUND = r"expected values of magnitude at most 1e\+100 .*got an integer of 401 digits"


@pytest.mark.parametrize("call, match", [
    (lambda: check_array([HUGE, 1], name="Y", ndim=1), rf"^Y: {_BOUND} at index 0$"),
    (lambda: check_array([[1, 2], [3, -HUGE]], name="Y"), rf"^Y: {_BOUND} at index \(1, 1\)$"),
    (lambda: check_array(HUGE, name="x", ndim=0), rf"^x: {_BOUND}$"),
    (lambda: check_array([10 ** 101], name="Y", ndim=1), r"^Y: .*got an integer of 102 digits at index 0$"),
    (lambda: check_array([10 ** 5000], name="Y", ndim=1), r"^Y: .*got an integer of about 5001 digits"),
    (lambda: check_positive(HUGE, name="radius"), r"^radius: expected a number > 0 of magnitude at most "
                                                   r"1e\+100, got an integer of 401 digits$"),
    (lambda: Constraints(goal=[HUGE, 0.0]), rf"^goal: {_BOUND}"),
    (lambda: Constraints(start_velocity=[0, -HUGE]), rf"^start_velocity: {_BOUND} at index 1"),
    (lambda: Constraints(via=[(0.5, [HUGE, 0])]), rf"^via\[0\]: via position: {_BOUND}"),
    (lambda: Constraints(goal_orientation=[HUGE, 0, 0, 1]), rf"^goal_orientation: {_BOUND}"),
    (lambda: ViaPoint([0, HUGE], phase=0.5), rf"^via position: {_BOUND} at index 1"),
    (lambda: ViaPoint([0, 1], index=HUGE), r"^ViaPoint index: expected a sample index within the signed "
                                            r"64-bit range, got an integer of 401 digits$"),
    (lambda: Sphere([HUGE, 0], 1.0), rf"^sphere center: {_BOUND}"),
    (lambda: Sphere([0, 0], HUGE), r"^sphere radius: .*got an integer of 401 digits$"),
    (lambda: Box([0, 0], [HUGE, 1]), rf"^box upper: {_BOUND}"),
    (lambda: Box([-HUGE, 0], [1, 1]), rf"^box lower: {_BOUND}"),
    (lambda: check_id(10 ** 30, name="cluster"), r"^cluster: expected an integer id within the signed "
                                                 r"64-bit range .*got an integer of 31 digits$"),
    (lambda: check_id(-2 ** 63 - 1, name="cluster"), r"^cluster: .*got an integer of 19 digits$"),
], ids=lambda v: "" if callable(v) else None)
def test_a_python_int_beyond_float64_is_one_value_error_naming_the_argument(call, match):
    with pytest.raises(ValueError, match=match) as info:
        call()
    assert "\n" not in str(info.value) and len(str(info.value)) < 250


def test_ints_inside_the_bound_are_exact_and_ids_reach_the_64_bit_edges():
    assert check_array([10 ** 30, 1], name="Y", ndim=1).tolist() == [1e30, 1.0]
    assert Constraints(goal=[10 ** 100, -10 ** 100]).goal.tolist() == [1e100, -1e100]
    assert check_id(2 ** 63 - 1, name="id") == 2 ** 63 - 1 and check_id(-2 ** 63, name="id") == -2 ** 63


@pytest.mark.parametrize("spec, match", [
    ("sphere:0,0," + "1" + "0" * 400, r"^obstacle: expected numbers of magnitude at most 1e\+100 .*got "
                                      r"'10000000000000000\.\.\.' in 'sphere:0,0,1000"),
    ("sphere:0,0,1e400", r"^obstacle: expected numbers of magnitude at most 1e\+100 .*got '1e400'"),
    ("sphere:0,0,-1e400", r"^obstacle: expected numbers of magnitude .*got '-1e400'"),
    ("sphere:0,0,Infinity", r"^obstacle: expected a finite number, got 'Infinity'"),
    ("box:0,0," + "x" * 500, r"^obstacle: expected a number, got 'xxxxxxxxxxxxxxxxx\.\.\.'"),
    ("cone:" + "1," * 400 + "1", r"^obstacle: expected 'sphere.*got 'cone:(1,){16}\.\.\.'$"),
])
def test_obstacle_specs_with_numbers_beyond_float64_are_refused_in_one_short_line(spec, match):
    with pytest.raises(ValueError, match=match) as info:
        parse_obstacle(spec)
    assert len(str(info.value)) < 250


def test_a_string_beyond_float64_is_shown_as_written():
    with pytest.raises(ValueError, match=r"^Y: expected finite values, got 1 non-finite value\(s\) "
                                         r"\('1e400', beyond float64's range, first at index 1\)$"):
        check_array(["0", "1e400"], name="Y", ndim=1)
    with pytest.raises(ValueError, match=r"\(NaN first at index 0\)"):
        check_array(["nan"], name="Y", ndim=1)
    assert np.isfinite(check_array(["1e100"], name="Y", ndim=1)).all()


@pytest.mark.parametrize("skill", [10 ** 30, -10 ** 30, 2 ** 63, 10 ** 400])
def test_library_reuse_of_a_cluster_id_beyond_64_bits_is_one_line(new_library, skill):
    from skillbank.pipeline import Library  # the pipeline layer, for this test only

    t = np.linspace(0.0, 1.0, 30)
    with Library(new_library("huge")) as lib:
        lib.add(Demonstration(t, {"position": np.c_[t, t, t]}), segment=False, label="reach")
        with pytest.raises(ValueError, match=r"^skill: expected an integer id within the signed "
                                             r"64-bit range \[-2\*\*63, 2\*\*63 - 1\], got an integer "
                                             r"of \d+ digits$"):
            lib.reuse(skill, Constraints(goal=[1.0, 1.0, 1.0]))
        with pytest.raises(ValueError, match=rf"^goal: {_BOUND}"):
            lib.reuse("reach", Constraints(goal=[HUGE, 1.0, 1.0]))
        with pytest.raises(ValueError, match=r"^skill: no primitive has cluster 9223372036854775807"):
            lib.reuse(2 ** 63 - 1, Constraints(goal=[1.0, 1.0, 1.0]))
