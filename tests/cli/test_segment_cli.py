import json
import re
from pathlib import Path

import numpy as np
import pytest

import skillbank.io as sio
from skillbank import Demonstration
from skillbank.cli import main
from skillbank.experiments import synthetic_multistream


def _run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("index", range(5))
def test_r_demos_give_three_segments(data_dir, capsys, index):
    path = str(data_dir / "seed" / "r_shape.h5")
    code, out, _ = _run(capsys, "segment", path, "--demo", str(index), "--json")
    assert code == 0
    doc = json.loads(out)
    assert doc["n_segments"] == 3
    assert len(doc["keypoints"]) == len(doc["keypoint_times"]) == 2
    assert set(doc["changepoints"]) == {"position"}


def test_paper_parameters_with_and_without_the_gate(data_dir, capsys):
    path = str(data_dir / "seed" / "r_shape.h5")
    paper = ["segment", path, "--demo", "3", "--window", "16", "--min-size", "64", "--threshold", "0.16",
             "--combine", "product", "--json"]
    code, out, _ = _run(capsys, *paper)
    assert code == 0 and json.loads(out)["n_segments"] == 3
    code, out, _ = _run(capsys, *paper, "--stop-ratio", "none")
    assert code == 0 and json.loads(out)["n_segments"] > 3


def test_three_button_cuts_at_the_presses_and_the_gripper(data_dir, capsys, tmp_path):
    code, out, _ = _run(
        capsys, "segment", str(data_dir / "seed" / "three_button_pressing_demo.h5"),
        "--stream", "joints", "--stream", "position", "--stream", "force", "--stream", "gripper",
        "--json", "--plot", str(tmp_path / "seg.png"), "--out", str(tmp_path / "segs"),
    )
    assert code == 0
    doc = json.loads(out)
    # gripper closing, the three presses, gripper opening (see tests/segmentation/test_evidence.py)
    assert doc["n_segments"] == 6 and doc["combine"] == "evidence"
    assert (tmp_path / "seg.png").read_bytes()[:4] == b"\x89PNG"
    files = sorted((tmp_path / "segs").glob("*.npz"))
    assert len(files) == 6
    assert sum(sio.read_npz(f).n_steps for f in files) == 4099


def test_npz_input_all_streams_seconds_window_and_text_output(capsys, tmp_path):
    demo = synthetic_multistream()
    path = sio.write_npz(demo, tmp_path / "demo.npz")
    code, out, _ = _run(capsys, "segment", str(path), "--window", "0.48s", "--json")
    assert code == 0
    doc = json.loads(out)
    assert doc["n_segments"] == 3
    assert np.abs(np.array(doc["keypoints"]) - demo.metadata["true_keypoints"]).max() <= 5
    code, out, _ = _run(capsys, "segment", str(path))
    assert code == 0 and "3 segment(s)" in out


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--window", "0"], r"segment: error: argument --window: expected an integer number of samples > 0 "
                            r"or seconds > 0 like '0.1s', got '0'"),
        (["--window", "0s"], r"segment: error: argument --window: expected .* seconds > 0 .*, got '0s'"),
        (["--window", "0.0e3 s"], r"argument --window: expected .*, got '0.0e3 s'"),
        (["--min-size=-0.5s"], r"argument --min-size: expected .* seconds > 0 .*, got '-0.5s'"),
        (["--window", "infs"], r"argument --window: expected .*, got 'infs'"),
        (["--window", "fasts"], r"argument --window: expected an integer number of samples"),
        (["--window", "fast"], r"argument --window: expected an integer number of samples"),
        (["--grace", "-1"], r"argument --grace: expected an integer number of samples >= 0 or seconds >= 0"),
        (["--threshold", "2"], r"threshold: expected a number in \[0.0, 1.0\], got 2.0"),
        (["--stream", "force"], r"streams: expected names among \['position'\]"),
        (["--mode", "magic"], r"argument --mode: invalid choice"),
        (["--stop-ratio", "half"], r"argument --stop-ratio: expected a number in \[0, 1\] or 'none'"),
        (["--stop-ratio", "2"], r"stop_ratio: expected a number in \[0.0, 1.0\], got 2.0"),
        (["--min-turn", "270"], r"min_turn: expected a number in \[0.0, 180.0\], got 270.0"),
        (["--demo", "1"], r"demo: expected an index in 0..0 \(.*demo.csv holds 1 demonstration\), got 1"),
    ],
)
def test_bad_parameters_give_one_line_and_status_2(capsys, tmp_path, args, match):
    path = sio.write_csv(synthetic_multistream(), tmp_path / "demo.csv")
    try:
        code = main(["segment", str(path), *args])
    except SystemExit as exc:  # argparse: a usage error
        code = exc.code
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("skillbank segment: error: ")
    assert re.search(match, err), err


def test_grace_takes_seconds_and_zero(capsys, tmp_path):
    path = sio.write_npz(synthetic_multistream(), tmp_path / "demo.npz")
    keypoints = {}
    for grace in ("0", "0s", "0.2s", "20"):
        code, out, err = _run(capsys, "segment", str(path), "--grace", grace, "--json")
        assert code == 0, err
        keypoints[grace] = json.loads(out)["keypoints"]
    # zero seconds is zero samples; 0.2 s is 20 samples at the demo's 0.01 s median period
    assert keypoints["0"] == keypoints["0s"] and keypoints["0.2s"] == keypoints["20"]


def test_bad_files(capsys, tmp_path):
    bad = tmp_path / "broken.h5"
    bad.write_bytes(b"not an hdf5 file at all")
    for path in (bad, tmp_path / "missing.csv", tmp_path / "x.xyz"):
        code, out, err = _run(capsys, "segment", str(path))
        assert code == 2 and out == ""
        assert err.count("\n") == 1 and "cannot read" in err


@pytest.mark.parametrize("which", ["seed/r_shape.h5", "rail/REACHING/1.mat"])
def test_multi_demo_file_says_which_demo_it_used(data_dir, capsys, which):
    path = str(data_dir / which)
    n = len(sio.load_all(path))
    code, out, err = _run(capsys, "segment", path)
    assert code == 0
    assert err == (f"skillbank segment: {path} holds {n} demonstrations; segmenting demonstration 0 "
                   f"(--demo 0..{n - 1} picks another)\n")
    assert out.startswith(f"{path} (demonstration 0 of {n}): ")
    code, out, err = _run(capsys, "segment", path, "--demo", "-1", "--json")
    assert code == 0 and err == ""  # chosen, so nothing to say
    doc = json.loads(out)
    assert (doc["demo"], doc["n_demos"]) == (n - 1, n)
    code, out, err = _run(capsys, "segment", path, "--demo", str(n))
    assert code == 2 and re.search(rf"demo: expected an index in 0..{n - 1} \(.* holds {n} demonstrations\), "
                                   rf"got {n}", err)


def test_single_demo_file_says_nothing(capsys, tmp_path):
    path = sio.write_npz(synthetic_multistream(), tmp_path / "one.npz")
    code, out, err = _run(capsys, "segment", str(path), "--json")
    assert code == 0 and err == ""
    assert (json.loads(out)["demo"], json.loads(out)["n_demos"]) == (0, 1)


def test_csv_out_writes_every_stream_and_replaces_an_earlier_run(capsys, tmp_path):
    demo = synthetic_multistream()  # streams position (3), gripper (1), force (3)
    path = sio.write_npz(demo, tmp_path / "pick.npz")
    out_dir = tmp_path / "segs"
    out_dir.mkdir()
    # left by an earlier run: more segments, and a stream this demo no longer has
    stale = ["pick_segment00_position.csv", "pick_segment07_position.csv", "pick_segment03_torque.csv"]
    # not this input's segments: kept
    others = ["pick_segment00.npz", "pick_segment00_segment00_position.csv", "picking_segment00_position.csv",
              "pick_segmentation.csv", "pick_segment01_notes.txt"]
    for name in stale + others:
        (out_dir / name).write_text("old\n")
    # an earlier run's segments are replaced with --force only: before any work, one line, nothing touched
    code, out, err = _run(capsys, "segment", str(path), "--out", str(out_dir), "--format", "csv", "--json")
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert err.startswith(f"skillbank segment: error: out: {str(out_dir / stale[0])!r} (and 2 more) exists; "
                          "give --force"), err
    assert sorted(p.name for p in out_dir.iterdir()) == sorted(stale + others)
    code, out, err = _run(capsys, "segment", str(path), "--out", str(out_dir), "--format", "csv", "--json",
                          "--force")
    assert code == 0, err
    doc = json.loads(out)
    expected = [f"pick_segment{i:02d}_{s}.csv" for i in range(3) for s in ("position", "gripper", "force")]
    assert [Path(f).name for f in doc["files"]] == expected
    assert sorted(Path(f).name for f in doc["removed"]) == sorted(stale[1:])
    assert sorted(p.name for p in out_dir.iterdir()) == sorted(expected + others)
    # every stream, every sample, once; values exact (write_csv keeps 17 digits)
    for name in ("position", "gripper", "force"):
        parts = [sio.read_csv(out_dir / f"pick_segment{i:02d}_{name}.csv") for i in range(3)]
        np.testing.assert_array_equal(np.concatenate([d["position"] for d in parts]), demo[name])
        np.testing.assert_array_equal(np.concatenate([d.t for d in parts]), demo.t)
        assert parts[0].metadata["columns"][0] == f"{name}_0"
    # text output lists what it wrote and what it removed
    (out_dir / "pick_segment05_force.csv").write_text("old\n")
    code, out, _ = _run(capsys, "segment", str(path), "--out", str(out_dir), "--format", "csv", "--force")
    assert code == 0
    wrote = [line.split("wrote ", 1)[1] for line in out.splitlines() if line.startswith("  wrote ")]
    assert [Path(w).name for w in wrote] == expected
    assert f"  removed {out_dir / 'pick_segment05_force.csv'} (from an earlier run)" in out.splitlines()


def test_plot_reports_the_file_written(capsys, tmp_path):
    path = sio.write_npz(synthetic_multistream(), tmp_path / "demo.npz")
    code, out, _ = _run(capsys, "segment", str(path), "--plot", str(tmp_path / "fig"))
    assert code == 0 and out.splitlines()[-1] == f"  wrote {tmp_path / 'fig.png'}"
    assert (tmp_path / "fig.png").read_bytes()[:4] == b"\x89PNG"
    code, out, err = _run(capsys, "segment", str(path), "--plot", str(tmp_path / "fig.bmp"))
    assert code == 2 and out == "" and "plot: expected a figure file name ending in one of" in err


def test_a_constant_stream_is_set_aside_with_a_note(cli, tmp_path):
    # was: exit 2, "the computation overflowed or became undefined"
    demo = synthetic_multistream()
    zero = sio.write_npz(type(demo)(demo.t, {**demo.streams, "torque": np.zeros((demo.n_steps, 3))}),
                         tmp_path / "zero.npz")
    plain = sio.write_npz(demo, tmp_path / "plain.npz")
    code, out, err = cli("segment", zero, "--json")
    assert code == 0
    assert err == ("skillbank segment: set aside stream 'torque' (constant: every value is 0), which carries "
                   "no information; the other streams were segmented as usual\n")
    doc = json.loads(out)
    assert doc["set_aside"] == {"torque": "constant: every value is 0"}
    assert doc["constant_columns"] == {"force": [0, 1]}  # the synthetic force pushes along z only
    code, out_plain, err_plain = cli("segment", plain, "--json")
    assert code == 0 and err_plain == ""
    assert doc["keypoints"] == json.loads(out_plain)["keypoints"] != []
    # text output: the same note, once
    code, out, err = cli("segment", zero)
    assert code == 0 and err.count("\n") == 1 and "set aside stream 'torque'" in err


def test_constant_columns_and_an_all_constant_recording_are_noted(cli, tmp_path):
    t = np.linspace(0.0, 4.0, 400)
    moving = np.column_stack([np.minimum(t, 1.0), np.clip(t - 2.0, 0.0, 1.0), np.full(400, 0.25)])
    path = sio.write_npz(Demonstration(t, {"position": moving}), tmp_path / "held_z.npz")
    code, out, err = cli("segment", path, "--json")
    assert code == 0 and json.loads(out)["constant_columns"] == {"position": [2]}
    assert err == ""  # reported, not noted
    still = sio.write_npz(Demonstration(t, {"position": np.zeros((400, 3))}), tmp_path / "still.npz")
    code, out, err = cli("segment", still, "--json")
    assert code == 0 and json.loads(out)["n_segments"] == 1
    assert err == ("skillbank segment: every stream is constant: stream 'position' (constant: every value is "
                   "0); nothing to segment, the demonstration is one segment\n")


def test_library_add_takes_a_recording_with_a_zero_force_sensor(cli, tmp_path):
    demo = synthetic_multistream()
    path = sio.write_npz(type(demo)(demo.t, {**demo.streams, "force": np.zeros((demo.n_steps, 3))}),
                         tmp_path / "zero_force.npz")
    assert cli("library", "init", tmp_path / "lib.db")[0] == 0
    code, out, err = cli("library", "add", tmp_path / "lib.db", path, "--json")
    assert code == 0, err
    report = json.loads(out)
    assert len(report["primitives"][0]) == 3  # as without the sensor
    assert report["set_aside"] == {"1": {"force": "constant: every value is 0"}}
    assert err == ("skillbank library add: set aside stream 'force' (constant: every value is 0) in "
                   "demonstration [1], which carries no information; the others were segmented as usual\n")
    # the provenance of the cut says so too
    from skillbank.pipeline import Library

    with Library(tmp_path / "lib.db") as lib:
        assert lib.provenance(1)["set_aside"] == {"force": "constant: every value is 0"}


def _ros_helpers():
    """tests/io/test_ros.py's bag writer and the three-button recording as topics (needs rosbags)."""
    import importlib.util

    pytest.importorskip("rosbags")
    path = Path(__file__).resolve().parents[1] / "io" / "test_ros.py"
    spec = importlib.util.spec_from_file_location("_segment_cli_ros", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def button_bag(data_dir, tmp_path_factory):
    """The three-button demonstration written as a ROS 2 bag (MCAP), each sensor on its own clock."""
    ros = _ros_helpers()
    recording, _ = ros.three_button_recording(data_dir)
    return ros.write_bag(tmp_path_factory.mktemp("bag"), "mcap", recording, name="buttons")


def test_a_rate_that_would_create_gigabytes_is_refused_before_it_does(button_bag, limited):
    # was: 23 GB, killed by the kernel
    code, out, err = limited("segment", button_bag, "--rate", "1e9", "--json", memory=1 << 30, timeout=60)
    assert code == 2 and out == ""
    assert err.count("\n") == 1, err
    assert re.fullmatch(r"skillbank segment: error: rate: 1e\+09 Hz over the recording's 27\.\d+ s would "
                        r"create 2\.7\de\+10 samples, more than the bound of 1e\+07; give a lower rate, or "
                        r"set SKILLBANK_MAX_SAMPLES to a larger count of samples\n", err), err


def test_the_sample_bound_is_set_by_the_environment(button_bag, cli, monkeypatch):
    code, out, err = cli("segment", button_bag, "--rate", "100", "--json")
    assert code == 0, err
    # under the bound: 27.7 s at 100 Hz is 2771 samples, cut at the gripper and the presses
    assert json.loads(out)["n_segments"] == 6
    monkeypatch.setenv("SKILLBANK_MAX_SAMPLES", "1000")
    code, out, err = cli("segment", button_bag, "--rate", "100")
    assert code == 2 and out == "" and err.count("\n") == 1
    assert "would create 2.77e+03 samples, more than the bound of 1000;" in err
    for bad in ("lots", "1.5", "1"):
        monkeypatch.setenv("SKILLBANK_MAX_SAMPLES", bad)
        code, out, err = cli("segment", button_bag, "--rate", "100")
        assert code == 2 and err == (f"skillbank segment: error: SKILLBANK_MAX_SAMPLES: expected a whole "
                                     f"number of samples >= 2, got {bad!r}\n")


def test_a_bag_with_a_zero_torque_sensor_is_segmented(tmp_path, cli):
    # the shape of the 10^6-message benchmark bags (benchmarks/bench_ingest.py), at 6000 messages:
    # joints and force x ramp, force y and z held at 0 and 1, torque all zero
    pytest.importorskip("rosbags")
    import importlib
    import sys

    benchmarks = str(Path(__file__).resolve().parents[2] / "benchmarks")
    if benchmarks not in sys.path:
        sys.path.insert(0, benchmarks)
    bag = importlib.import_module("bench_ingest").write_bag(tmp_path, "mcap", 6000)
    code, out, err = cli("segment", bag, "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["set_aside"] == {"torque": "constant: every value is 0"}
    assert doc["constant_columns"] == {"force": [1, 2]}
    assert err == ("skillbank segment: set aside stream 'torque' (constant: every value is 0), which carries "
                   "no information; the other streams were segmented as usual\n")


@pytest.mark.parametrize(("rate", "match"), [
    ("nan", r"rate: expected a number > 0, got nan"),
    ("inf", r"rate: expected a number > 0, got inf"),
    ("-100", r"rate: expected a number > 0, got -100\.0"),
    ("0", r"rate: expected a number > 0, got 0\.0"),
])
def test_a_rate_that_is_no_rate_is_refused(button_bag, cli, rate, match):
    code, out, err = cli("segment", button_bag, f"--rate={rate}")
    assert code == 2 and out == "" and err.count("\n") == 1
    assert re.search(match, err), err
