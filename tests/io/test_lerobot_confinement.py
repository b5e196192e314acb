"""LeRobot datasets that point outside their folder or bend their own metadata (issue 23, items 3-9)."""

from __future__ import annotations

import json
import re

import numpy as np
import pyarrow.parquet as pq
import pytest

from skillbank.io import FormatError, load_all, read_lerobot
from skillbank.io._lerobot_checks import MAX_FIELD_WIDTH
from skillbank.pipeline import Library

from .test_lerobot import _episodes, write_lerobot

OUTSIDE = "outside/x.parquet"


def raises_format(root, match: str):
    """A one-line FormatError about ``root`` whose reason holds ``match``."""
    return pytest.raises(FormatError, match=f"^cannot read '{re.escape(str(root))}': .*{match}")


def _info(root, **changes):
    path = root / "meta" / "info.json"
    info = json.loads(path.read_text())
    info.update(changes)
    path.write_text(json.dumps(info))


def _one_line(code, out, err):
    return code == 2 and out == "" and len(err.strip().splitlines()) == 1 and "Traceback" not in err


@pytest.fixture
def dataset(tmp_path):
    """A v2.1 dataset in ``tmp_path/lab/ds`` and, beside it, another one's data file ``tmp_path/outside``."""
    root = write_lerobot(tmp_path / "lab" / "ds", "v2.1", _episodes())
    other = write_lerobot(tmp_path / "other", "v2.1", _episodes(tasks=("secret", "secret", "secret")))
    (tmp_path / "outside").mkdir()
    (other / "data" / "chunk-000" / "episode_000000.parquet").rename(tmp_path / OUTSIDE)
    return root


@pytest.mark.parametrize("data_path", ["../../outside/x.parquet", "data/../../../outside/x.parquet",
                                       "ABSOLUTE"])
def test_a_data_path_that_leaves_the_folder_is_refused(dataset, data_path):
    data_path = str(dataset.parents[1] / OUTSIDE) if data_path == "ABSOLUTE" else data_path
    _info(dataset, data_path=data_path)
    with raises_format(dataset, f"the data file {re.escape(repr(data_path))} leaves the dataset folder: "
                                r"expected a relative path inside it \(no '..', not absolute\); skillbank "
                                "reads nothing outside the folder$"):
        read_lerobot(dataset)


def test_symbolic_links_out_of_the_folder_are_refused_and_links_inside_followed(dataset):
    data = dataset / "data" / "chunk-000"
    first = pq.read_table(data / "episode_000000.parquet")
    (data / "episode_000000.parquet").unlink()
    (data / "episode_000000.parquet").symlink_to(dataset.parents[1] / OUTSIDE)
    with raises_format(dataset, r"the data file 'data/chunk-000/episode_000000.parquet' is a symbolic link "
                                r"\(or under one\) to '.*outside/x.parquet', outside the dataset folder"):
        read_lerobot(dataset)
    # the same file through a link that stays inside: read as it is
    pq.write_table(first, dataset / "kept.parquet")
    (data / "episode_000000.parquet").unlink()
    (data / "episode_000000.parquet").symlink_to(dataset / "kept.parquet")
    assert read_lerobot(dataset, episodes=[0])[0].n_steps == 5
    # metadata files are held to the same rule
    info = dataset / "meta" / "info.json"
    info.rename(dataset.parents[1] / "outside" / "info.json")
    info.symlink_to(dataset.parents[1] / "outside" / "info.json")
    with raises_format(dataset, r"the file 'meta/info.json' is a symbolic link .* outside the dataset"):
        load_all(dataset)


def test_the_whole_meta_folder_linked_out_is_refused(dataset, tmp_path):
    (dataset / "meta").rename(tmp_path / "meta_elsewhere")
    (dataset / "meta").symlink_to(tmp_path / "meta_elsewhere")
    with raises_format(dataset, r"the file 'meta/info.json' is a symbolic link \(or under one\)"):
        read_lerobot(dataset)


@pytest.mark.parametrize(("data_path", "message"), [
    ("data/{episode_index:>1000000000}.parquet",
     rf"field \{{episode_index:>1000000000\}} asks for a width of 1000000000 characters; expected at most "
     rf"{MAX_FIELD_WIDTH}"),
    ("data/{episode_index:.99999d}.parquet", r"asks for a precision of 99999 characters"),
    ("data/{episode_index:065d}.parquet", r"asks for a width of 65 characters; expected at most 64"),
    ("data/{episode_index:{episode_chunk}}.parquet", r"field .* has a format spec that is not a plain width"),
    ("data/{episode_index.__class__}.parquet",
     r"expected fields among \['\{episode_chunk\}', '\{episode_index\}'\], found "
     r"\{episode_index.__class__\}$"),
    ("data/{episode_index!r}.parquet", r"expected fields among"),
    ("data/{0}.parquet", r"expected fields among"),
    ("data/{episode_index", r"is not a valid template: "),
    ("d" * 2000, r"expected 'data_path' in meta/info.json of at most 1024 characters, found 2000$"),
    (5, r"expected 'data_path' in meta/info.json to be a string \(a path template\), found int 5$"),
])
def test_template_fields_are_bounded_before_formatting(dataset, data_path, message):
    _info(dataset, data_path=data_path)
    with raises_format(dataset, message):
        read_lerobot(dataset)


def test_the_widest_allowed_field_still_reads(dataset):
    data = dataset / "data" / "chunk-000"
    for ep in range(3):
        (data / f"episode_{ep:06d}.parquet").rename(data / f"{ep:064d}.parquet")
    _info(dataset, data_path="data/chunk-{episode_chunk:03d}/{episode_index:064d}.parquet")
    assert [d.n_steps for d in read_lerobot(dataset)] == [5, 7, 4]


def test_a_gigabyte_field_width_exits_2_within_a_small_memory_limit(dataset, limited):
    _info(dataset, data_path="data/{episode_index:>1000000000}.parquet")
    code, out, err = limited("segment", dataset, "--json", memory=1 << 30, timeout=60)
    assert _one_line(code, out, err) and "asks for a width of 1000000000 characters" in err, err


def _rewrite_jsonl(path, edit):
    rows = [json.loads(line) for line in path.read_text().splitlines()]
    path.write_text("".join(edit(k, r) + "\n" for k, r in enumerate(rows)))


@pytest.mark.parametrize(("change", "message"), [
    ({"chunks_size": 0}, r"expected a positive 'chunks_size' in meta/info.json .* found 0$"),
    ({"chunks_size": "1000"}, r"expected 'chunks_size' in meta/info.json to be an integer in \[0, 10+\], "
                              r"found '1000'$"),
    ({"chunks_size": 2.5}, r"expected 'chunks_size' .* found 2.5$"),
    ("FPS", r"expected 'fps' in meta/info.json to be a number in \(0, 1e\+06\] frames per second, "
            r"found 1000+\.\.\.$"),
    ({"fps": 1e7}, r"found 10000000.0$"),
    ({"features": {"observation.state": {"dtype": "float32", "shape": "3"}}},
     r"expected 'shape' of feature 'observation.state' in meta/info.json to be a list of 1 to 8 non-negative "
     r"integers like \[6\], found '3'$"),
    ({"features": {"observation.state": {"dtype": "float32", "shape": [2.0]}}}, r"found \[2.0\]$"),
])
def test_bad_info_fields_are_one_line(dataset, change, message):
    if change == "FPS":  # 10^400 written out: JSON reads it as an int that no float holds
        text = (dataset / "meta" / "info.json").read_text()
        (dataset / "meta" / "info.json").write_text(re.sub(r'"fps": \d+', '"fps": 1' + "0" * 400, text))
    else:
        _info(dataset, **change)
    with raises_format(dataset, message):
        read_lerobot(dataset)


@pytest.mark.parametrize(("edit", "message"), [
    (lambda k, r: json.dumps(r).replace(f'"episode_index": {k}', '"episode_index": 1e999'),
     r"expected 'episode_index' of row 0 of the episodes index to be an integer in \[0, 10+\], found inf$"),
    (lambda k, r: json.dumps({**r, "episode_index": -1}), r"'episode_index' of row 0 .* found -1$"),
    (lambda k, r: json.dumps({**r, "episode_index": 10**13}), r"found 10000000000000$"),
    (lambda k, r: json.dumps({**r, "length": 1e999}), r"expected the 'length' of episode 0 to be an integer"),
    (lambda k, r: json.dumps({**r, "tasks": "pick"}), r"expected the 'tasks' of episode 0 to be a list of "
                                                      r"strings, found 'pick'$"),
    (lambda k, r: json.dumps({**r, "episode_index": 0}), r"episode 0 is listed twice in the episodes index$"),
    (lambda k, r: json.dumps([r]), r"expected an 'episode_index' in every row of the episodes index, row 0 "
                                   "has "),
])
def test_bad_episode_rows_are_one_line(dataset, edit, message):
    _rewrite_jsonl(dataset / "meta" / "episodes.jsonl", edit)
    with raises_format(dataset, message):
        read_lerobot(dataset)


def test_tasks_need_a_task_index(dataset, tmp_path):
    _rewrite_jsonl(dataset / "meta" / "tasks.jsonl", lambda k, r: json.dumps({"task": r["task"]}))
    with raises_format(dataset, r"expected 'task_index' and 'task' \(a string\) in every row of "
                                r"meta/tasks.jsonl, row 0 has \['task'\]$"):
        read_lerobot(dataset)
    v3 = write_lerobot(tmp_path / "v3", "v3.0", _episodes())
    tasks = v3 / "meta" / "tasks.parquet"
    pq.write_table(pq.read_table(tasks).drop(["task_index"]), tasks)
    with raises_format(v3, r"expected columns 'task_index' and 'task' in meta/tasks.parquet, found "):
        read_lerobot(v3)


def test_v3_data_file_indices_are_checked(tmp_path):
    root = write_lerobot(tmp_path / "v3", "v3.0", _episodes())
    index = root / "meta" / "episodes" / "chunk-000" / "file-000.parquet"
    table = pq.read_table(index)
    column = table.column_names.index("data/file_index")
    pq.write_table(table.set_column(column, "data/file_index", [[1.5, 0.0, 1.0]]), index)
    with raises_format(root, r"expected 'data/file_index' of episode 0 to be an integer in \[0, 10+\], "
                             r"found 1.5$"):
        read_lerobot(root)


# ---------------------------------------------------------------- the task string labels the primitives


def _reaches(k: int) -> np.ndarray:
    return np.column_stack([np.linspace(0.0, 1.0 + k, 40), np.zeros(40)])


def test_library_add_labels_each_episode_with_its_task(tmp_path, cli, table_rows):
    episodes = [{"task": task, "features": {"observation.state": _reaches(k)}}
                for k, task in enumerate(["pick up the cube", "open the drawer", "pick up the cube"])]
    root = write_lerobot(tmp_path / "ds", "v2.1", episodes)
    db = tmp_path / "lib.sqlite"
    assert cli("library", "init", db)[0] == 0
    before = table_rows(db)
    code, out, err = cli("library", "add", db, root, "--whole")
    assert _one_line(code, out, err) and table_rows(db) == before
    assert "read one feature as the position: --feature observation.state=position" in err, err
    code, out, err = cli("library", "add", db, root, "--whole", "--feature", "observation.state=position",
                         "--json")
    assert code == 0, err
    code, out, err = cli("library", "list", db, "--json")
    labels = {p["demonstration"]: p["label"] for p in json.loads(out)["primitives"]}
    assert labels == {1: "pick up the cube", 2: "open the drawer", 3: "pick up the cube"}
    code, out, err = cli("library", "add", db, root, "--whole", "--feature", "observation.state=position",
                         "--episodes", "1", "--label", "drawer", "--json")
    assert code == 0, err
    code, out, err = cli("library", "list", db, "--json")
    assert [p["label"] for p in json.loads(out)["primitives"] if p["demonstration"] == 4] == ["drawer"]


def test_the_task_label_is_recorded_as_coming_from_the_metadata(tmp_path, new_library):
    episodes = [{"task": "wipe", "features": {"observation.state": _reaches(0)}}]
    root = write_lerobot(tmp_path / "ds", "v3.0", episodes)
    with Library(new_library()) as lib:
        report = lib.add_files([root], segment=False,
                               reader_options={"features": ["observation.state=position"]})
        did = report["demonstrations"][0]
        assert [p.label for p in lib.primitives()] == ["wipe"]
        assert lib.provenance(did)["label_from"] == "metadata['task']"
        report = lib.add_files([root], segment=False, label="mine",
                               reader_options={"features": ["observation.state=position"]})
        (other,) = report["demonstrations"]
        assert [p.label for p in lib.primitives(demonstration=other)] == ["mine"]
        assert "label_from" not in lib.provenance(other)


def test_a_data_file_is_held_to_the_read_bound_before_it_is_read(tmp_path, monkeypatch):
    root = write_lerobot(tmp_path / "ds", "v2.1", _episodes(lengths=(2000, 7, 4)))
    data = root / "data" / "chunk-000" / "episode_000000.parquet"
    meta = pq.ParquetFile(data).metadata
    declared = sum(meta.row_group(i).total_byte_size for i in range(meta.num_row_groups))
    assert declared > max(f.stat().st_size for f in (root / "meta").iterdir())  # the metadata stays readable
    monkeypatch.setenv("SKILLBANK_MAX_READ_BYTES", str(declared - 1))
    with raises_format(root, rf"'data/chunk-000/episode_000000.parquet' \(2000 rows\) would take {declared} "
                             rf"bytes in memory, .* passes the bound of {declared - 1} bytes read from one "
                             "file; set SKILLBANK_MAX_READ_BYTES to read more$"):
        read_lerobot(root)
    monkeypatch.setenv("SKILLBANK_MAX_READ_BYTES", str(declared))
    assert read_lerobot(root, episodes=[0])[0].n_steps == 2000


def test_library_add_and_segment_of_a_dataset_reading_outside_exit_2(dataset, tmp_path, cli, table_rows):
    _info(dataset, data_path="../../outside/x.parquet")
    db = tmp_path / "lib.sqlite"
    assert cli("library", "init", db)[0] == 0
    before = table_rows(db)
    for argv in (("library", "add", db, dataset, "--feature", "observation.state=position", "--whole"),
                 ("segment", dataset, "--json")):
        code, out, err = cli(*argv)
        assert _one_line(code, out, err) and "leaves the dataset folder" in err, err
        assert "secret" not in err
    assert table_rows(db) == before


def test_metadata_text_is_held_to_the_read_bound(dataset, monkeypatch):
    size = (dataset / "meta" / "info.json").stat().st_size
    monkeypatch.setenv("SKILLBANK_MAX_READ_BYTES", str(size - 1))
    with raises_format(dataset, rf"'meta/info.json' would take {size} bytes in memory, .* passes the bound "
                                rf"of {size - 1} bytes read from one file"):
        read_lerobot(dataset)
