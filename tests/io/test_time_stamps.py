"""No silent sample loss (issue 12, item 5).

Before the fix a robot recording whose joint clock is all zeros was read (and stored by
``library add --whole``) as a 1-sample demonstration, 4,098 samples dropped, exit status 0: the
readers dropped repeated stamps without a word. Now stamps that repeat, run backwards or never
advance are an error naming the stream and the sample, unless the reader is asked for the
documented repair ``repair_time="drop"``.
"""

from __future__ import annotations

import json
import types

import h5py
import numpy as np
import pytest

from skillbank.cli import _main
from skillbank.io import read_handwriting_h5, read_robot_h5
from skillbank.io._errors import check_clock
from skillbank.io._lasa import _to_demo


def _set(path, key, value):
    with h5py.File(path, "a") as h5:
        del h5[key]
        h5[key] = value


def test_robot_all_zero_joint_clock_is_an_error(robot_h5, raises_format_error):
    # The layout of seed/three_button_pressing_demo.h5, 4099 samples, joint_time all zeros.
    path = robot_h5(n=4099, clock_shape=(4099, 2))
    match = (r"stream 'joints' \(clock 'joint_state_info/joint_time'\): expected strictly increasing time "
             r"stamps, but sample 1 \(0\.0 s\) repeats sample 0 \(0\.0 s\); 4098 of 4098 steps do not "
             r"increase \(the clock never advances, so no repair applies\)$")
    with raises_format_error(path, match):
        read_robot_h5(path)
    with raises_format_error(path, "the clock never advances"):
        read_robot_h5(path, repair_time="drop")


def test_robot_all_zero_joint_clock_is_not_added_to_a_library(robot_h5, tmp_path, capsys):
    path = robot_h5(n=200, clock_shape=(200, 2))
    db = tmp_path / "lib.db"
    assert _main.main(["library", "init", str(db)]) == 0
    capsys.readouterr()
    assert _main.main(["library", "add", str(db), str(path), "--whole"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "stream 'joints'" in err and "sample 1" in err
    assert _main.main(["library", "list", str(db), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["n_demonstrations"] == 0


def test_robot_repeated_stamp_names_the_sample_and_drop_repairs_it(robot_h5, raises_format_error):
    path = robot_h5(n=50)
    with h5py.File(path, "r") as h5:
        clock = h5["wrench_info/wrench_time"][()]
    clock[7] = clock[6]
    _set(path, "wrench_info/wrench_time", clock)
    match = (r"stream 'force' \(clock 'wrench_info/wrench_time'\): .* sample 7 .* repeats sample 6 .*"
             r"1 of 49 steps do not increase; read with repair_time='drop'")
    with raises_format_error(path, match):
        read_robot_h5(path)
    demo = read_robot_h5(path, repair_time="drop")
    # The force clock lost a sample; the time base (the joints' clock) did not.
    assert demo.n_steps == 50 and "dropped_samples" not in demo.metadata
    with h5py.File(path, "r") as h5:
        joints = h5["joint_state_info/joint_time"][()]
    joints[3] = joints[2]
    _set(path, "joint_state_info/joint_time", joints)
    demo = read_robot_h5(path, repair_time="drop")
    assert demo.n_steps == 49 and demo.metadata["dropped_samples"] == 1


def test_backwards_time_is_an_error_even_with_repair(robot_h5, raises_format_error):
    path = robot_h5(n=30)
    with h5py.File(path, "r") as h5:
        clock = h5["gripper_info/gripper_time"][()]
    clock[[10, 11]] = clock[[11, 10]]
    _set(path, "gripper_info/gripper_time", clock)
    for repair in (None, "drop"):
        with raises_format_error(path, r"stream 'gripper' .*sample 11 \(.* s\) runs back from sample 10 .*"
                                       r"1 of 29 steps do not increase$"):
            read_robot_h5(path, repair_time=repair)


def test_handwriting_repeated_stamp(handwriting_h5, raises_format_error):
    path = handwriting_h5()
    _set(path, "normalized/1/t", np.r_[1000.0, 1000.0, 1010.0 + 10.0 * np.arange(18)])
    with raises_format_error(path, r"demonstration 'normalized/1' \(clock 'normalized/1/t'\): .*sample 1 "
                                   r"\(0\.0 s\) repeats sample 0"):
        read_handwriting_h5(path)
    demos = read_handwriting_h5(path, repair_time="drop")
    assert [d.n_steps for d in demos] == [20, 19, 20]
    assert demos[1].metadata["dropped_samples"] == 1


def test_lasa_repeated_stamp():
    raw = types.SimpleNamespace(t=np.array([[0.0, 0.1, 0.1, 0.2]]), pos=np.arange(8.0).reshape(2, 4))
    with pytest.raises(ValueError, match=r"cannot read 'LASA Angle demonstration 3': stream 'position' "
                                         r"\(clock 't'\): .*sample 2 \(0\.1 s\) repeats sample 1"):
        _to_demo(raw, "Angle", 3, None)
    assert _to_demo(raw, "Angle", 3, "drop").metadata["dropped_samples"] == 1


@pytest.mark.parametrize("reader", [read_robot_h5, read_handwriting_h5])
def test_repair_time_is_checked(reader, tmp_path):
    with pytest.raises(ValueError, match=r"^repair_time: expected None .* or 'drop' .*, got 'sort'$"):
        reader(tmp_path / "missing.h5", repair_time="sort")


def test_check_clock_reports_the_first_offender_and_a_count():
    t = np.r_[np.arange(5.0), np.full(1000, 4.0)]
    with pytest.raises(ValueError, match=r"sample 5 \(4\.0 s\) repeats sample 4 \(4\.0 s\); 1000 of") as info:
        check_clock("f.csv", t, where="stream 'x'")
    assert len(str(info.value)) < 300
    kept, n_dropped = check_clock("f.csv", t, where="stream 'x'", repair_time="drop")
    assert kept.tolist() == [0.0, 1.0, 2.0, 3.0, 4.0] and n_dropped == 1000


def test_cli_repair_time_flag(robot_h5, tmp_path, capsys):
    """The commands that read files take ``--repair-time drop``; without it the repeat is an error."""
    path = robot_h5(n=200)
    with h5py.File(path, "r") as h5:
        joints = h5["joint_state_info/joint_time"][()]
    joints[3] = joints[2]
    _set(path, "joint_state_info/joint_time", joints)
    db = tmp_path / "lib.db"
    assert _main.main(["library", "init", str(db)]) == 0
    assert _main.main(["library", "add", str(db), str(path), "--whole", "--json"]) == 2
    assert "sample 3" in capsys.readouterr().err
    argv = ["library", "add", str(db), str(path), "--whole", "--json"]
    assert _main.main([*argv, "--repair-time", "drop"]) == 0
    capsys.readouterr()
    assert _main.main(["library", "list", str(db), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["primitives"][0]["n_steps"] == 199
    assert _main.main(["segment", str(path), "--stream", "position", "--json"]) == 2
    assert "read with repair_time='drop'" in capsys.readouterr().err
    assert _main.main(["segment", str(path), "--stream", "position", "--repair-time", "drop", "--json"]) == 0
    assert _main.main(["edit", str(path), "--repair-time", "drop", "--json"]) == 0
    with pytest.raises(SystemExit):
        _main.main(["edit", str(path), "--repair-time", "interpolate"])
