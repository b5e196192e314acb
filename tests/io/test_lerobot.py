"""LeRobot datasets, layouts v2.1 and v3.0, written here with pyarrow as LeRobot lays them out."""

from __future__ import annotations

import json
import re
import sys

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from hypothesis import given
from hypothesis import strategies as st

from skillbank.core import Demonstration
from skillbank.io import FormatError, detect_format, load_all, read_lerobot, read_robot_h5, select_episodes
from skillbank.segmentation import MultimodalSegmenter

BOOKKEEPING = {"timestamp": ("float32", [1]), "frame_index": ("int64", [1]), "episode_index": ("int64", [1]),
               "index": ("int64", [1]), "task_index": ("int64", [1])}


def _column(values: np.ndarray, dtype: str, fixed: bool):
    kind = pa.from_numpy_dtype(np.dtype(dtype))
    if values.ndim == 1:
        return pa.array(values.astype(dtype), type=kind)
    lists = pa.list_(kind, values.shape[1]) if fixed else pa.list_(kind)
    return pa.array(list(values.astype(dtype)), type=lists)


def write_lerobot(root, version: str, episodes: list[dict], *, fps=30, dtype="float32", names=None,
                  per_file=2, episode_tasks=True):
    """Write a LeRobot dataset: each episode is ``{"features": {name: (n, d) or (n,)}, "task": str}``.

    v2.1: one parquet file per episode and JSON-lines metadata; v3.0: ``per_file``
    episodes per data file (fixed-size lists), the episodes index and the
    tasks as parquet (tasks as the pandas index column, as pandas writes it).
    """
    tasks = list(dict.fromkeys(ep["task"] for ep in episodes))
    first = episodes[0]["features"]
    features = {k: {"dtype": dtype, "shape": [1 if v.ndim == 1 else v.shape[1]],
                    "names": (names or {}).get(k)} for k, v in first.items()}
    features["observation.images.top"] = {"dtype": "video", "shape": [3, 48, 64], "names": ["c", "h", "w"]}
    features.update({k: {"dtype": d, "shape": s, "names": None} for k, (d, s) in BOOKKEEPING.items()})
    v2 = version.startswith("v2")
    info = {"codebase_version": version, "robot_type": "ur5e", "fps": fps, "chunks_size": 1000,
            "total_episodes": len(episodes), "features": features,
            "data_path": "data/chunk-{episode_chunk:03d}/episode_{episode_index:06d}.parquet" if v2 else
            "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"}
    (root / "meta").mkdir(parents=True)
    (root / "meta" / "info.json").write_text(json.dumps(info))
    tables, rows, start = [], [], 0
    for ep, episode in enumerate(episodes):
        n = len(next(iter(episode["features"].values())))
        columns = {k: _column(v, dtype, fixed=not v2) for k, v in episode["features"].items()}
        columns.update(timestamp=pa.array(np.arange(n, dtype=np.float32) / fps),
                       frame_index=pa.array(np.arange(n)), episode_index=pa.array(np.full(n, ep)),
                       index=pa.array(start + np.arange(n)),
                       task_index=pa.array(np.full(n, tasks.index(episode["task"]))))
        tables.append(pa.table(columns))
        row = {"episode_index": ep, "length": n, "tasks": [episode["task"]]} if episode_tasks else \
            {"episode_index": ep, "length": n}
        if not v2:
            row.update({"data/chunk_index": 0, "data/file_index": ep // per_file, "dataset_from_index": start,
                        "dataset_to_index": start + n, "stats/observation.state/mean": [0.0, 0.0]})
        rows.append(row)
        start += n
    if v2:
        for ep, table in enumerate(tables):
            path = root / info["data_path"].format(episode_chunk=0, episode_index=ep)
            path.parent.mkdir(parents=True, exist_ok=True)
            pq.write_table(table, path)
        (root / "meta" / "episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
        (root / "meta" / "tasks.jsonl").write_text("".join(json.dumps({"task_index": i, "task": t}) + "\n"
                                                           for i, t in enumerate(tasks)))
        return root
    for f in range(0, len(tables), per_file):
        path = root / info["data_path"].format(chunk_index=0, file_index=f // per_file)
        path.parent.mkdir(parents=True, exist_ok=True)
        pq.write_table(pa.concat_tables(tables[f:f + per_file]), path)
    index = root / "meta" / "episodes" / "chunk-000" / "file-000.parquet"
    index.parent.mkdir(parents=True)
    pq.write_table(pa.Table.from_pylist(rows), index)
    pq.write_table(pa.table({"task_index": pa.array(range(len(tasks))), "__index_level_0__": tasks}),
                   root / "meta" / "tasks.parquet")
    return root


def _episodes(lengths=(5, 7, 4), tasks=("pick", "place", "pick")):
    out = []
    for ep, (n, task) in enumerate(zip(lengths, tasks, strict=True)):
        state = np.column_stack([10.0 * ep + np.arange(n), -np.arange(n, dtype=float)])
        out.append({"task": task, "features": {"observation.state": state, "action": -state,
                                               "next.reward": np.arange(n, dtype=float) / 2}})
    return out


def raises_format(path, match: str):
    return pytest.raises(FormatError, match=f"^cannot read '{re.escape(str(path))}': {match}")


@pytest.mark.parametrize("version", ["v2.1", "v3.0"])
def test_episodes_read_back(tmp_path, version):
    root = write_lerobot(tmp_path / "ds", version, _episodes(), names={"observation.state": ["x", "y"]})
    assert detect_format(root) == "lerobot"
    demos = read_lerobot(root)
    assert [d.n_steps for d in demos] == [5, 7, 4]
    for ep, demo in enumerate(demos):
        assert demo.stream_names == ["observation.state", "action", "next.reward"]
        n = demo.n_steps
        np.testing.assert_array_equal(demo["observation.state"], np.column_stack([10.0 * ep + np.arange(n),
                                                                                   -np.arange(n)]))
        np.testing.assert_array_equal(demo["action"], -demo["observation.state"])
        np.testing.assert_array_equal(demo["next.reward"].ravel(), np.arange(n) / 2)
        np.testing.assert_allclose(demo.t, np.arange(n) / 30)
        assert demo.metadata["episode"] == ep and demo.metadata["label"] == ["pick", "place", "pick"][ep]
    meta = demos[0].metadata
    assert meta["format"] == "lerobot" and meta["codebase_version"] == version and meta["fps"] == 30
    assert meta["robot_type"] == "ur5e" and meta["tasks"] == ["pick"]
    assert meta["column_names"] == {"observation.state": ["x", "y"]}
    assert meta["skipped_features"] == {"observation.images.top": "video"}
    assert json.loads(json.dumps(meta, allow_nan=False)) == meta
    chosen = load_all(root, reader_options={"episodes": "1:3", "features": ["action"], "topics": ["/x=y"]})
    assert [d.metadata["episode"] for d in chosen] == [1, 2] and chosen[0].stream_names == ["action"]


def test_label_from_the_task_index(tmp_path):
    root = write_lerobot(tmp_path / "ds", "v2.1", _episodes(), episode_tasks=False)
    assert [d.metadata["label"] for d in read_lerobot(root)] == ["pick", "place", "pick"]
    root = write_lerobot(tmp_path / "v3", "v3.0", _episodes(), episode_tasks=False)
    assert [d.metadata["label"] for d in read_lerobot(root, episodes=[2, 1])] == ["pick", "place"]


@pytest.mark.parametrize(("episodes", "chosen"), [
    (None, [0, 1, 2]), (1, [1]), ([2, 0], [2, 0]), ("0:2", [0, 1]), ("1:", [1, 2]), (":1", [0]),
    ("2,0", [2, 0]), (range(1, 3), [1, 2]), (slice(0, 5), [0, 1, 2]), (np.int64(2), [2]),
])
def test_episode_selection(episodes, chosen):
    assert select_episodes(episodes, [0, 1, 2]) == chosen


@pytest.mark.parametrize(("episodes", "message"), [
    ([3], r"episodes: expected numbers among \[0, 1, 2\], got missing \[3\]"),
    ("5:9", r"episodes: expected a selection holding at least one of \[0, 1, 2\], got slice\(5, 9, None\)"),
    ("a-b", r"episodes: expected 'a:b', '1,4,7' or numbers, got 'a-b'"),
    (True, r"episodes: expected None, an int, a list of ints, a range or 'a:b', got True"),
    ([0.5], r"episodes: expected None, an int, a list of ints, a range or 'a:b', got \[0.5\]"),
    (slice(0, 3, 2), r"episodes: expected a range with step 1, got slice\(0, 3, 2\)"),
])
def test_episode_selection_errors(episodes, message):
    with pytest.raises(ValueError, match=message):
        select_episodes(episodes, [0, 1, 2])


@given(st.sets(st.integers(0, 50), min_size=1), st.integers(-5, 60), st.integers(-5, 60))
def test_a_range_selects_what_is_inside_it(available, lo, hi):
    inside = sorted(a for a in available if lo <= a < hi)
    if inside:
        assert select_episodes(f"{lo}:{hi}", available) == inside == select_episodes(range(lo, hi), available)
    else:
        with pytest.raises(ValueError, match="episodes: expected a selection holding at least one of"):
            select_episodes(f"{lo}:{hi}", available)


def test_frames_of_episodes_apart_in_a_file(tmp_path):
    root = write_lerobot(tmp_path / "ds", "v3.0", _episodes(lengths=(5, 7, 4)), per_file=3)
    data = root / "data" / "chunk-000" / "file-000.parquet"
    table = pq.read_table(data)
    order = np.argsort(table.column("frame_index").to_numpy(), kind="stable")  # episodes' frames interleaved
    pq.write_table(table.take(order), data)
    demos = read_lerobot(root)
    assert [d.n_steps for d in demos] == [5, 7, 4]
    np.testing.assert_array_equal(demos[1]["observation.state"][:, 0], 10 + np.arange(7))


def test_features_option(tmp_path):
    root = write_lerobot(tmp_path / "ds", "v3.0", _episodes())
    assert read_lerobot(root, features="next.reward")[0].stream_names == ["next.reward"]
    with pytest.raises(ValueError, match=r"features: expected names among \['observation.state', 'action', "
                                         r"'next.reward'\], got \['observation.images.top'\]"):
        read_lerobot(root, features=["observation.images.top"])
    # FEATURE=STREAM names the stream
    demo = read_lerobot(root, features=["observation.state=position", "action"])[1]
    assert demo.stream_names == ["position", "action"]
    np.testing.assert_array_equal(demo["position"], -demo["action"])
    with pytest.raises(ValueError, match=r"features: expected one distinct, non-empty stream name per "
                                         r"feature, got \['action', 'action'\]"):
        read_lerobot(root, features=["observation.state=action", "action"])
    with pytest.raises(ValueError, match=r"features: expected names or 'FEATURE=STREAM' strings, got \[3\]"):
        read_lerobot(root, features=[3])


def test_what_is_not_a_dataset(tmp_path):
    with raises_format(tmp_path / "absent", r"expected a LeRobot dataset folder \(holding meta/info.json\), "
                                           r"found no such file or folder$"):
        read_lerobot(tmp_path / "absent")
    with raises_format(tmp_path, r"expected a LeRobot dataset folder \(holding meta/info.json\), found a "
                                 r"folder without meta/info.json$"):
        read_lerobot(tmp_path)
    root = write_lerobot(tmp_path / "ds", "v2.1", _episodes())
    (root / "meta" / "info.json").write_text("{not json")
    with raises_format(root, r"invalid JSON in 'meta/info.json': "):
        read_lerobot(root)
    (root / "meta" / "info.json").write_text("[1, 2]")
    with raises_format(root, r"expected a JSON object in meta/info.json, found list$"):
        load_all(root)
    root = write_lerobot(tmp_path / "no_index", "v2.1", _episodes())
    (root / "meta" / "episodes.jsonl").unlink()
    with raises_format(root, r"expected 'meta/episodes.jsonl', found none$"):
        read_lerobot(root)
    (root / "meta" / "episodes.jsonl").write_text('{"episode_index": 0}\n{"broken\n')
    with raises_format(root, r"invalid JSON lines in 'meta/episodes.jsonl': "):
        read_lerobot(root)


@pytest.mark.parametrize(("changes", "message"), [
    ({"fps": 0}, r"expected 'fps' in meta/info.json to be a number in \(0, 1e\+06\] frames per second, "
                 "found 0$"),
    ({"fps": "fast"}, r"expected 'fps' in meta/info.json to be a number .* found 'fast'$"),
    ({"codebase_version": "v1.6"}, r"expected codebase_version v2.x or v3.x in meta/info.json, found "
                                   r"'v1.6'$"),
    ({"features": []}, r"expected 'features' to be an object in meta/info.json$"),
    ({"data_path": None}, r"expected keys \['data_path'\] in meta/info.json, found \["),
    ({"features": {"observation.images.top": {"dtype": "video"}}},
     r"expected numeric features in meta/info.json, found \['observation.images.top'\]$"),
    ({"data_path": "data/{missing}.parquet"}, r"'data_path' in meta/info.json: expected fields among "
                                              r"\['\{episode_chunk\}', '\{episode_index\}'\], found "
                                              r"\{missing\}$"),
])
def test_bad_info(tmp_path, changes, message):
    root = write_lerobot(tmp_path / "ds", "v2.1", _episodes())
    info = json.loads((root / "meta" / "info.json").read_text())
    info.update(changes)
    if info["data_path"] is None:
        del info["data_path"]
    (root / "meta" / "info.json").write_text(json.dumps(info))
    with raises_format(root, message):
        read_lerobot(root)


def test_bad_data(tmp_path):
    root = write_lerobot(tmp_path / "v2", "v2.1", _episodes())
    data = root / "data" / "chunk-000" / "episode_000001.parquet"
    data.write_bytes(data.read_bytes()[:200])
    with raises_format(root, r"episode 1: corrupt data file 'data/chunk-000/episode_000001.parquet': "):
        read_lerobot(root)
    assert len(read_lerobot(root, episodes=[0, 2])) == 2
    data.unlink()
    with raises_format(root, r"episode 1: expected data file 'data/chunk-000/episode_000001.parquet', found "
                             r"none$"):
        read_lerobot(root, episodes=1)
    root = write_lerobot(tmp_path / "v3", "v3.0", _episodes(lengths=(5, 7, 4)))
    rows = pq.read_table(root / "meta" / "episodes" / "chunk-000" / "file-000.parquet").to_pylist()
    rows[2]["length"] = 9
    pq.write_table(pa.Table.from_pylist(rows), root / "meta" / "episodes" / "chunk-000" / "file-000.parquet")
    with raises_format(root, r"episode 2: the episodes index says 9 frames, "
                             r"'data/chunk-000/file-001.parquet' holds 4$"):
        read_lerobot(root)
    # A column with a missing value, and one that is not numbers.
    table = pq.read_table(root / "data" / "chunk-000" / "file-000.parquet")
    state = table.column("observation.state").to_pylist()
    state[3] = None
    pq.write_table(table.set_column(table.column_names.index("observation.state"), "observation.state",
                                    pa.array(state, type=pa.list_(pa.float32()))),
                   root / "data" / "chunk-000" / "file-000.parquet")
    with raises_format(root, r"episode 0: column 'observation.state': expected numbers without nulls, found "
                             r"float with 1 null\(s\)$"):
        read_lerobot(root)
    pq.write_table(table.drop_columns(["action"]), root / "data" / "chunk-000" / "file-000.parquet")
    with raises_format(root, r"episode 0: expected columns \['action'\] in "
                             r"'data/chunk-000/file-000.parquet'"):
        read_lerobot(root)
    for f in (root / "meta" / "episodes").rglob("*.parquet"):
        f.unlink()
    with raises_format(root, r"expected episode files meta/episodes/chunk-\*/file-\*.parquet, found none$"):
        read_lerobot(root)


def test_missing_pyarrow_names_the_extra(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    with pytest.raises(ImportError, match=r"^reading LeRobot datasets needs the 'pyarrow' package: "
                                          r"pip install skillbank\[lerobot\]$"):
        read_lerobot(tmp_path)


@pytest.mark.parametrize("version", ["v2.1", "v3.0"])
def test_three_button_reads_as_the_hdf5_file_of_the_same_samples(uniform_three_button, tmp_path, version):
    # A LeRobot dataset keeps the frames at fps, in float64 here: the same numbers as the HDF5 file.
    u = uniform_three_button
    s = u["streams"]
    features = {"observation.state": s["joints"], "observation.ee_pos": s["position"],
                "observation.ee_quat": s["orientation"],
                "observation.wrench": np.hstack([s["force"], s["torque"]]),
                "observation.gripper": s["gripper"][:, 0],
                "action": np.vstack([s["joints"][1:], s["joints"][-1:]])}
    half = {k: v[:500] for k, v in features.items()}
    root = write_lerobot(tmp_path / "ds", version, [{"task": "press three buttons", "features": features},
                                                    {"task": "press one", "features": half}],
                         fps=int(u["rate"]), dtype="float64", names={"observation.state": u["joint_names"]})
    demo, short = read_lerobot(root)
    assert short.n_steps == 500 and demo.metadata["label"] == "press three buttons"
    assert demo.metadata["column_names"]["observation.state"] == u["joint_names"]
    h5 = read_robot_h5(u["h5"])
    np.testing.assert_allclose(demo.t, h5.t, atol=1e-9)
    as_h5 = Demonstration(demo.t, {"joints": demo["observation.state"],
                                   "position": demo["observation.ee_pos"],
                                   "orientation": demo["observation.ee_quat"],
                                   "force": demo["observation.wrench"][:, :3],
                                   "torque": demo["observation.wrench"][:, 3:],
                                   "gripper": demo["observation.gripper"]})
    for name in h5.stream_names:
        np.testing.assert_allclose(as_h5[name], h5[name], atol=1e-9, err_msg=name)
    ours, theirs = MultimodalSegmenter().fit(as_h5).result_, MultimodalSegmenter().fit(h5).result_
    assert ours.n_segments == theirs.n_segments > 1 and ours.bounds == theirs.bounds


def test_segment_command_reads_chosen_episodes(tmp_path, cli):
    # episodes long enough to segment: a reach out and back along x, twice, at 30 fps
    t = np.arange(180) / 30.0
    x = np.where(t < 3.0, 0.5 - 0.5 * np.cos(np.pi * t / 3.0), 0.5 + 0.5 * np.cos(np.pi * (t - 3.0) / 3.0))
    state = np.column_stack([x, 0.2 * x, np.zeros_like(x)])
    episodes = [{"task": f"reach {k}", "features": {"observation.state": state + k}} for k in range(3)]
    root = write_lerobot(tmp_path / "ds", "v3.0", episodes)
    code, out, err = cli("segment", root, "--episodes", "1:3", "--demo", "1", "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["n_demos"] == 2 and doc["demo"] == 1 and set(doc["changepoints"]) == {"observation.state"}
    code, out, err = cli("segment", root, "--episodes", "5:9")
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1 and "episodes" in err


def test_library_add_takes_the_chosen_episodes(tmp_path, cli):
    episodes = [{"task": f"reach {k}", "features": {"observation.state": np.column_stack(
        [np.linspace(0.0, 1.0 + k, 40), np.zeros(40)])}} for k in range(4)]
    root = write_lerobot(tmp_path / "ds", "v2.1", episodes)
    db = tmp_path / "lib.sqlite"
    assert cli("library", "init", db)[0] == 0
    code, out, err = cli("library", "add", db, root, "--episodes", "1:3", "--whole", "--json")
    # a library keeps primitives of a 'position' stream: the state is read as one
    assert code == 2 and "expected a 'position' stream" in err
    code, out, err = cli("library", "add", db, root, "--episodes", "1:3", "--feature",
                         "observation.state=position", "--whole", "--json")
    assert code == 0, err
    report = json.loads(out)
    assert len(report["demonstrations"]) == 2 and report["failed"] == {}
    code, out, err = cli("library", "list", db, "--json")
    assert code == 0, err
