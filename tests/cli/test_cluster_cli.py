"""``skillbank cluster``: feature matrices and folders of trajectories."""

from __future__ import annotations

import json

import numpy as np
import pytest

import skillbank
import skillbank.io as sio
from skillbank.cli import _cluster

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"




def _blobs(n=20, seed=0):
    rng = np.random.default_rng(seed)
    centres = np.array([[0.0, 0.0, 0.0], [6.0, 0.0, 0.0], [0.0, 6.0, 3.0]])
    return np.concatenate([rng.normal(c, 0.4, size=(n, 3)) for c in centres])


@pytest.fixture(scope="module")
def trajectory_folder(tmp_path_factory):
    """Two kinds of motion, six of each, from different starts, goals, sizes and facings; mixed CSV/NPZ.

    The facings vary by up to +-30 degrees, as one lab's recordings in one robot frame do: the default
    features keep the direction of motion in the recording frame (``--features heading`` drops it)."""
    folder = tmp_path_factory.mktemp("trajs")
    rng = np.random.default_rng(1)
    t = np.linspace(0.0, 2.0, 120)
    s = t / t[-1]
    for i in range(12):
        start, size, yaw = rng.uniform(-1, 1, 3), rng.uniform(0.5, 2.0), rng.uniform(-0.5, 0.5)
        if i % 2 == 0:  # reach down onto a point
            base = np.column_stack([s, 0.3 * s ** 2, -0.8 * s])
        else:  # slide along the table in an arc
            base = np.column_stack([np.sin(2 * s), 1 - np.cos(2 * s), 0 * s])
        c, n = np.cos(yaw), np.sin(yaw)
        Y = start + size * base @ np.array([[c, n, 0.0], [-n, c, 0.0], [0.0, 0.0, 1.0]])
        demo = skillbank.Demonstration(t, {"position": Y + rng.normal(0, 1e-4, Y.shape)})
        writer = sio.write_csv if i % 3 else sio.write_npz
        writer(demo, folder / f"demo{i:02d}.{'csv' if i % 3 else 'npz'}")
    (folder / "notes.md").write_text("not a trajectory\n")
    return folder


def test_feature_matrix_npy_json(cli, tmp_path):
    path = tmp_path / "X.npy"
    np.save(path, _blobs())
    code, out, _ = cli("cluster", path, "--json", "--seed", "0")
    assert code == 0
    doc = json.loads(out)
    assert set(doc) == {"labels", "n_clusters", "energy", "criterion", "min_separation", "significance",
                        "sizes", "separation", "p_values"}
    # and the significance test that kept each cluster apart from its nearest one (issue 44)
    assert all(p <= doc["significance"] for p in doc["p_values"])
    assert doc["n_clusters"] == 3 and isinstance(doc["energy"], float)
    # the choice explained: each cluster's size and its separation from the nearest other one
    assert doc["sizes"] == [20, 20, 20] and doc["criterion"] == "hierarchy"
    assert all(s >= doc["min_separation"] for s in doc["separation"])
    labels = np.array(doc["labels"])
    assert labels.shape == (60,)
    assert all(len(set(labels[k * 20:(k + 1) * 20])) == 1 for k in range(3))


@pytest.mark.parametrize("header", [True, False])
def test_feature_matrix_csv_with_or_without_header(cli, tmp_path, header):
    path = tmp_path / "X.csv"
    np.savetxt(path, _blobs(), delimiter=",", header="f1,f2,f3" if header else "", comments="")
    code, out, _ = cli("cluster", path, "--json", "--seed", "0")
    assert code == 0
    assert json.loads(out)["n_clusters"] == 3


def test_feature_matrix_text_output_and_plot(cli, tmp_path):
    path = tmp_path / "X.npy"
    np.save(path, _blobs())
    fig = tmp_path / "clusters.png"
    code, out, _ = cli("cluster", path, "--plot", fig, "--seed", "1")
    assert code == 0
    assert "60 sample(s), 3 feature(s) -> 3 cluster(s)" in out
    assert out.count("  cluster ") == 3 and f"wrote {fig}" in out
    assert fig.read_bytes()[:8] == PNG_MAGIC


def test_folder_of_trajectories(cli, trajectory_folder, tmp_path):
    fig = tmp_path / "trajs.png"
    code, out, _ = cli("cluster", trajectory_folder, "--json", "--seed", "0", "--plot", fig)
    assert code == 0
    doc = json.loads(out)
    assert doc["files"] == sorted(f"demo{i:02d}.{'csv' if i % 3 else 'npz'}" for i in range(12))
    labels = np.array(doc["labels"])
    assert doc["n_clusters"] == 2
    assert len(set(labels[0::2])) == 1 and len(set(labels[1::2])) == 1 and labels[0] != labels[1]
    assert fig.read_bytes()[:8] == PNG_MAGIC


@pytest.mark.parametrize("features", ["dtw", "none"])
def test_folder_other_featurisers(cli, trajectory_folder, features):
    code, out, _ = cli("cluster", trajectory_folder, "--features", features, "--json")
    assert code == 0
    doc = json.loads(out)
    assert len(doc["labels"]) == 12 and doc["n_clusters"] >= 1


def test_folder_angular_features(cli, trajectory_folder):
    code, out, _ = cli("cluster", trajectory_folder, "--features", "angular", "--representatives", "0,1",
                       "--json", "--seed", "0")
    assert code == 0
    doc = json.loads(out)
    # Angular similarity is not invariant to the random headings here, so only the shape is checked.
    assert len(doc["labels"]) == 12 and doc["n_clusters"] == len(set(doc["labels"]))


def test_rail_files_in_a_folder(cli, data_dir, tmp_path):
    """A folder of real RAIL writing and reaching demos written as NPZ files."""
    rail = data_dir / "rail"
    demos = sio.load_rail(rail, classes=["writing"])[:8] + sio.load_rail(rail, classes=["reaching"])[:8]
    for i, demo in enumerate(demos):
        only_position = skillbank.Demonstration(demo.t, {"position": demo["position"]})
        sio.write_npz(only_position, tmp_path / f"{i:02d}.npz")
    code, out, _ = cli("cluster", tmp_path, "--json", "--seed", "0")
    assert code == 0
    labels = np.array(json.loads(out)["labels"])
    # Writing forms one cluster; no cluster mixes writing and reaching (small samples may split reaching).
    assert len(set(labels[:8])) == 1 and labels[0] not in set(labels[8:])


@pytest.mark.parametrize(
    ("make", "extra", "match"),
    [
        (lambda p: p / "missing.csv", [], r"input: no such file or folder"),
        (lambda p: (p / "a.json").write_text("{}") and p / "a.json", [],
         r"a.json': expected a feature matrix \(.csv, .npy\), got extension '.json'"),
        (lambda p: np.save(p / "o.npy", np.array([{"a": 1}], dtype=object)) or p / "o.npy", [],
         r"cannot read .*o.npy': expected a numeric .npy array: Object arrays cannot be loaded"),
        (lambda p: np.save(p / "v.npy", np.arange(4.0)) or p / "v.npy", [],
         r"features: expected a 2-D array, got 1-D"),
        (lambda p: (p / "bad.csv").write_text("a,b\n1,2\n3,x\n") and p / "bad.csv", [],
         r"bad.csv': line 3, column 2: expected a number, found 'x'"),
        (lambda p: (p / "ragged.csv").write_text("1,2\n3\n") and p / "ragged.csv", [],
         r"ragged.csv': line 2: expected 2 values as in the first row, found 1"),
        (lambda p: (p / "empty.csv").write_text("\n") and p / "empty.csv", [], r"found an empty file"),
        (lambda p: (p / "nan.csv").write_text("1,2\nnan,3\n") and p / "nan.csv", [],
         r"features: expected finite values, got 1 non-finite value"),
        (lambda p: np.save(p / "X.npy", np.eye(3)) or p / "X.npy", ["--features", "dtw"],
         r"features: 'dtw' needs a folder of trajectories"),
        (lambda p: np.save(p / "X.npy", np.eye(3)) or p / "X.npy", ["--stretch", "-1"],
         r"stretch: expected a number >= 0, got -1.0"),
        (lambda p: (p / "empty").mkdir() or p / "empty", [], r"expected trajectory files .* found none"),
    ],
)
def test_bad_input_one_line_exit_2(cli, tmp_path, make, extra, match):
    import re

    path = make(tmp_path)
    code, out, err = cli("cluster", path, *extra)
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and err.startswith("skillbank cluster: error: ")
    assert re.search(match, err), err


def test_angular_needs_representatives(trajectory_folder):
    args = type("Args", (), {"input": trajectory_folder, "features": "angular", "representatives": None,
                             "repair_time": None,
                             "seed": 0, "stretch": 1.2, "json": True, "plot": None})()
    with pytest.raises(ValueError, match=r"representatives: --features angular needs --representatives"):
        _cluster.run(args)
    args.representatives = "0,99"
    with pytest.raises(ValueError, match=r"representatives: expected indices in 0..11, got \[?99\]?"):
        _cluster.run(args)


def test_none_needs_equal_lengths(tmp_path):
    for i, n in enumerate((30, 40)):
        sio.write_npz(skillbank.Demonstration.from_array(np.random.default_rng(i).normal(size=(n, 2))),
                      tmp_path / f"{i}.npz")
    args = type("Args", (), {"input": tmp_path, "features": "none", "representatives": None,
                             "repair_time": None,
                             "seed": 0, "stretch": 1.2, "json": True, "plot": None})()
    with pytest.raises(ValueError, match=r"features: 'none' .* got lengths \[?30, 40\]?"):
        _cluster.run(args)


def test_progress_bar_for_many_files(tmp_path, capsys):
    for i in range(25):
        demo = skillbank.Demonstration.from_array(np.full((5, 2), float(i)))
        sio.write_npz(demo, tmp_path / f"{i:02d}.npz")
    names, demos = sio.load_folder(tmp_path)
    assert names[0] == "00.npz" and len(demos) == 25
    assert "loading" in capsys.readouterr().err


def test_cluster_ids_are_the_same_in_text_json_and_figure(cli, trajectory_folder, tmp_path, monkeypatch):
    from skillbank.plotting import plot_cluster_comparison

    # the globals the command's function really uses (doctest collection may import a second copy)
    scope = plot_cluster_comparison.__globals__
    titles = []
    draw = scope["_trajectory_panel"]
    monkeypatch.setitem(scope, "_trajectory_panel", lambda *a: titles.append(a[-1]) or draw(*a))
    code, out, _ = cli("cluster", trajectory_folder, "--json", "--seed", "0")
    doc = json.loads(out)
    members = {k: [f for f, label in zip(doc["files"], doc["labels"], strict=True) if label == k]
               for k in range(doc["n_clusters"])}
    assert sorted(set(doc["labels"])) == [0, 1]
    code, out, _ = cli("cluster", trajectory_folder, "--seed", "0", "--plot", tmp_path / "c")
    assert code == 0
    text = {int(line.split()[1].rstrip(":")): line.split(": ", 2)[2].split(", ")
            for line in out.splitlines() if line.startswith("  cluster ")}
    assert text == members  # 0..k-1 with the same members as --json
    assert sorted(titles) == [f"cluster {k} ({len(members[k])}, separation {doc['separation'][k]:.1f})"
                              for k in range(2)]
    assert out.splitlines()[-1] == f"  wrote {tmp_path / 'c.png'}"
