import json

import numpy as np
import pytest

import skillbank.io as sio
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
             "--json"]
    code, out, _ = _run(capsys, *paper)
    assert code == 0 and json.loads(out)["n_segments"] == 3
    code, out, _ = _run(capsys, *paper, "--stop-ratio", "none")
    assert code == 0 and json.loads(out)["n_segments"] > 3


def test_three_button_gives_four_segments(data_dir, capsys, tmp_path):
    code, out, _ = _run(
        capsys, "segment", str(data_dir / "seed" / "three_button_pressing_demo.h5"),
        "--stream", "joints", "--stream", "position", "--stream", "force", "--stream", "gripper",
        "--json", "--plot", str(tmp_path / "seg.png"), "--out", str(tmp_path / "segs"),
    )
    assert code == 0
    doc = json.loads(out)
    assert doc["n_segments"] == 4
    assert (tmp_path / "seg.png").read_bytes()[:4] == b"\x89PNG"
    files = sorted((tmp_path / "segs").glob("*.npz"))
    assert len(files) == 4
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
        (["--window", "0"], r"window: expected an integer > 0, got 0"),
        (["--window", "fast"], r"argument --window: expected an integer number of samples"),
        (["--threshold", "2"], r"threshold: expected a number in \[0.0, 1.0\], got 2.0"),
        (["--stream", "force"], r"streams: expected names among \['position'\]"),
        (["--mode", "magic"], r"argument --mode: invalid choice"),
        (["--stop-ratio", "half"], r"argument --stop-ratio: expected a number in \[0, 1\] or 'none'"),
        (["--stop-ratio", "2"], r"stop_ratio: expected a number in \[0.0, 1.0\], got 2.0"),
        (["--min-turn", "270"], r"min_turn: expected a number in \[0.0, 180.0\], got 270.0"),
    ],
)
def test_bad_parameters_give_one_line_and_status_2(capsys, tmp_path, args, match):
    path = sio.write_csv(synthetic_multistream(), tmp_path / "demo.csv")
    with pytest.raises(SystemExit) if args[1] in ("fast", "magic", "half") \
            else _nullcontext():
        code = main(["segment", str(path), *args])
        assert code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert pytest.importorskip("re").search(match, err)


def test_bad_files(capsys, tmp_path):
    bad = tmp_path / "broken.h5"
    bad.write_bytes(b"not an hdf5 file at all")
    for path in (bad, tmp_path / "missing.csv", tmp_path / "x.xyz"):
        code, out, err = _run(capsys, "segment", str(path))
        assert code == 2 and out == ""
        assert err.count("\n") == 1 and "cannot read" in err


class _nullcontext:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False
