"""Reader for LeRobot datasets (layouts v2.1 and v3.0), with ``pyarrow`` and without ``lerobot`` or torch.

A dataset is a folder: ``meta/info.json`` (fps, features, the data file
template), an episodes index (``meta/episodes.jsonl`` in v2.1, parquet files
under ``meta/episodes/`` in v3.0), the tasks, and parquet data files (one per
episode in v2.1, ``data/chunk-*/file-*.parquet`` shared by many episodes in
v3.0).
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Iterable
from pathlib import Path

import numpy as np
from tqdm import tqdm

from ..core import Demonstration
from ..core._validation import summarise
from ._confine import ReadBudget, inside
from ._errors import FormatError, check_clock, open_regular, reading
from ._lerobot_checks import (
    check_fps,
    check_index,
    check_rows,
    check_shape,
    check_task_rows,
    check_template,
    format_template,
)

__all__ = ["read_lerobot", "LEROBOT_INFO", "select_episodes"]

#: A folder holding this file is a LeRobot dataset.
LEROBOT_INFO = "meta/info.json"
# Columns LeRobot adds to every frame: indices and the clock, not data.
_BOOKKEEPING = ("timestamp", "frame_index", "episode_index", "index", "task_index")
_NOT_NUMBERS = ("video", "image", "string")
_RANGE = re.compile(r"^\s*(-?\d*)\s*:\s*(-?\d*)\s*$")


def _missing_pyarrow():
    return ImportError("reading LeRobot datasets needs the 'pyarrow' package: pip install skillbank[lerobot]")


def select_episodes(episodes, available, *, name: str = "episodes") -> list[int]:
    """The episode numbers chosen by ``episodes`` among ``available`` (sorted ints).

    ``None`` takes all; an int one; a ``range``, ``slice`` or ``"a:b"``
    string the available numbers in that half-open range; a list of ints or
    ``"1,4,7"`` exactly those (each must exist).

    Examples
    --------
    >>> select_episodes("2:5", [0, 1, 2, 3, 4, 5, 6])
    [2, 3, 4]
    >>> select_episodes("1,4", range(6))
    [1, 4]
    """
    available = sorted(int(a) for a in available)
    if episodes is None:
        return available
    if isinstance(episodes, str):
        match = _RANGE.match(episodes)
        if match:
            lo, hi = (int(v) if v not in ("", "-") else None for v in match.groups())
            episodes = slice(lo, hi)
        else:
            try:
                episodes = [int(v) for v in episodes.split(",")]
            except ValueError:
                raise ValueError(f"{name}: expected 'a:b', '1,4,7' or numbers, got {episodes!r}") from None
    if isinstance(episodes, range):
        episodes = slice(episodes.start, episodes.stop) if episodes.step == 1 else list(episodes)
    if isinstance(episodes, slice):
        if episodes.step not in (None, 1):
            raise ValueError(f"{name}: expected a range with step 1, got {episodes!r}")
        lo = -np.inf if episodes.start is None else episodes.start
        hi = np.inf if episodes.stop is None else episodes.stop
        chosen = [a for a in available if lo <= a < hi]
    else:
        if isinstance(episodes, (int, np.integer)) and not isinstance(episodes, bool):
            episodes = [episodes]
        if not isinstance(episodes, Iterable) or not all(
                isinstance(e, (int, np.integer)) and not isinstance(e, bool) for e in episodes):
            raise ValueError(f"{name}: expected None, an int, a list of ints, a range or 'a:b', "
                             f"got {episodes!r}")
        chosen = [int(e) for e in episodes]
        missing = [e for e in chosen if e not in set(available)]
        if missing:
            raise ValueError(f"{name}: expected numbers among [{summarise(map(str, available), limit=8)}], "
                             f"got missing {missing}")
    if not chosen:
        raise ValueError(f"{name}: expected a selection holding at least one of "
                         f"[{summarise(map(str, available), limit=8)}], got {episodes!r}")
    return chosen


def _member(root: Path, rel: str, what: str = "file") -> Path | None:
    """A file of the dataset, checked to be a regular file inside it (no link out); None when absent."""
    path = inside(root, rel, what=what)
    return path if path.exists() else None


def _text(root: Path, rel: str) -> str | None:
    path = _member(root, rel)
    if path is None:
        return None
    with open_regular(path) as fh, reading(root, f"expected UTF-8 text in '{rel}'"):
        ReadBudget(root).take(os.fstat(fh.fileno()).st_size, f"'{rel}'")
        return fh.read().decode("utf-8")


def _parquet(root: Path, path: Path, pq, what: str):
    """A parquet file of the dataset, read through a descriptor checked to be a regular file.

    Its size in memory, as its footer declares it, is checked against the
    read bound first: a column of one repeated value compresses to nothing.
    """
    with open_regular(path) as fh, reading(root, what):
        parquet = pq.ParquetFile(fh)
        meta = parquet.metadata
        size = sum(meta.row_group(i).total_byte_size for i in range(meta.num_row_groups))
        rel = path.relative_to(os.path.realpath(root)).as_posix()
        ReadBudget(root).take(size, f"'{rel}' ({meta.num_rows} rows)")
        return parquet.read()


def _json(root: Path, rel: str):
    text = _text(root, rel)
    if text is None:
        raise FormatError(root, f"expected '{rel}', found none")
    with reading(root, f"invalid JSON in '{rel}'"):
        return json.loads(text)


def _jsonl(root: Path, rel: str) -> list:
    text = _text(root, rel)
    if text is None:
        raise FormatError(root, f"expected '{rel}', found none")
    with reading(root, f"invalid JSON lines in '{rel}'"):
        return [json.loads(line) for line in text.splitlines() if line.strip()]


def _version(info: dict) -> str:
    return "v2" if info["codebase_version"].startswith("v2") else "v3"


def _info(root: Path) -> dict:
    info = _json(root, LEROBOT_INFO)
    if not isinstance(info, dict):
        raise FormatError(root, f"expected a JSON object in {LEROBOT_INFO}, found {type(info).__name__}")
    missing = [k for k in ("codebase_version", "fps", "features", "data_path") if k not in info]
    if missing:
        raise FormatError(root, f"expected keys {missing} in {LEROBOT_INFO}, found "
                          f"[{summarise(map(repr, sorted(info)))}]")
    check_fps(root, info["fps"])
    if not isinstance(info["features"], dict):
        raise FormatError(root, f"expected 'features' to be an object in {LEROBOT_INFO}")
    version = info["codebase_version"]
    if not isinstance(version, str) or not re.match(r"^v[23]\.", version):
        raise FormatError(root, f"expected codebase_version v2.x or v3.x in {LEROBOT_INFO}, found "
                          f"{str(version)[:40]!r}")
    check_template(root, info["data_path"], _version(info))
    if _version(info) == "v2" and check_index(root, info.get("chunks_size", 1000),
                                             f"'chunks_size' in {LEROBOT_INFO}") == 0:
        raise FormatError(root, f"expected a positive 'chunks_size' in {LEROBOT_INFO} (episodes per chunk "
                          "folder, LeRobot writes 1000), found 0")
    return info


def _episodes(root: Path, info: dict, pq) -> dict[int, dict]:
    """The episodes index: episode number -> its row (length, tasks, and in v3 its data file)."""
    if _version(info) == "v2":
        rows = _jsonl(root, "meta/episodes.jsonl")
    else:
        files = sorted((root / "meta" / "episodes").glob("chunk-*/file-*.parquet"))
        if not files:
            raise FormatError(root, "expected episode files meta/episodes/chunk-*/file-*.parquet, found none")
        rows = []
        for f in files:
            member = _member(root, f.relative_to(root).as_posix())
            table = _parquet(root, member, pq, "corrupt episodes index")
            with reading(root, "corrupt episodes index"):
                keep = [c for c in table.column_names if not c.startswith(("stats/", "videos/"))]
                rows += table.select(keep).to_pylist()
    if not rows:
        raise FormatError(root, "expected an episodes index with an 'episode_index' per episode, found none")
    return check_rows(root, rows, _version(info))


def _tasks(root: Path, info: dict, pq) -> dict[int, str]:
    if _version(info) == "v2":
        if _member(root, "meta/tasks.jsonl") is None:
            return {}
        return check_task_rows(root, _jsonl(root, "meta/tasks.jsonl"), "meta/tasks.jsonl")
    path = _member(root, "meta/tasks.parquet")
    if path is None:
        return {}
    table = _parquet(root, path, pq, "corrupt meta/tasks.parquet")
    # pandas writes the task strings as the index; its column is named after it.
    text = next((c for c in ("task", "__index_level_0__") if c in table.column_names),
                next((c for c in table.column_names if c != "task_index"), None))
    if text is None or "task_index" not in table.column_names:
        raise FormatError(root, f"expected columns 'task_index' and 'task' in meta/tasks.parquet, found "
                          f"[{summarise(map(repr, table.column_names))}]")
    with reading(root, "corrupt meta/tasks.parquet"):
        rows = [{"task_index": i, "task": t} for i, t in zip(table.column("task_index").to_pylist(),
                                                             table.column(text).to_pylist(), strict=True)]
    return check_task_rows(root, rows, "meta/tasks.parquet")


def _numbers(root, column, n: int, width: int, where: str) -> np.ndarray:
    """A parquet column (numbers or lists of numbers, nested) as an ``(n, width)`` float array."""
    import pyarrow as pa  # optional extra (skillbank[lerobot])

    array = column.combine_chunks() if hasattr(column, "combine_chunks") else column
    nulls = array.null_count
    while pa.types.is_list(array.type) or pa.types.is_large_list(array.type) or \
            pa.types.is_fixed_size_list(array.type):
        array = array.flatten()
        nulls += array.null_count
    if nulls or not (pa.types.is_integer(array.type) or pa.types.is_floating(array.type)
                     or pa.types.is_boolean(array.type)):
        raise FormatError(root, f"{where}: expected numbers without nulls, found {array.type} with "
                          f"{nulls} null(s)")
    values = np.asarray(array.to_numpy(zero_copy_only=False), dtype=float)
    if values.size != n * width:
        raise FormatError(root, f"{where}: expected {n} frames of {width} values, found {values.size} values")
    return values.reshape(n, width)


def _rows_by_episode(table):
    """``{episode: (first row, last row + 1)}`` of a data file, or None when it has no episode column.

    LeRobot writes each episode's frames together; one slice per episode
    then replaces a scan of the whole file per episode. (Frames of an
    episode found apart are given as row indices instead.)
    """
    if "episode_index" not in table.column_names:
        return None
    owners = np.asarray(table.column("episode_index").to_numpy(zero_copy_only=False))
    starts = np.flatnonzero(np.diff(owners, prepend=owners[:1] - 1))  # where the episode changes
    stops = np.append(starts[1:], owners.size)
    rows = {int(owners[a]): (int(a), int(b)) for a, b in zip(starts, stops, strict=True)}
    if len(rows) != starts.size:  # frames of an episode apart: take them by index, in file order
        return {int(e): np.flatnonzero(owners == e) for e in np.unique(owners)}
    return rows


def _feature_names(spec: dict):
    names = spec.get("names")
    if isinstance(names, dict):  # v2 writes {"motors": [...]}
        names = next(iter(names.values()), None) if len(names) == 1 else None
    return [str(n) for n in names] if isinstance(names, list) and all(
        isinstance(n, (str, int)) for n in names) else None


def read_lerobot(path, *, episodes=None, features=None, progress=False) -> list[Demonstration]:
    """Read the episodes of a LeRobot dataset (layouts v2.1 and v3.0).

    Needs the optional extra ``skillbank[lerobot]`` (``pyarrow``); neither
    ``lerobot`` nor torch is imported. Each episode becomes a Demonstration
    whose streams are the dataset's numeric features.

    Parameters
    ----------
    path : str or path-like
        The dataset folder (holding ``meta/info.json``).
    episodes : None, int, list of int, range, slice or str, optional
        Which episodes (their ``episode_index``): ``"0:100"``, ``"3,7"``,
        ``range(10)``; default all. See :func:`select_episodes`.
    features : list of str, optional
        Which features become streams; default every numeric feature but
        the bookkeeping columns (``timestamp``, ``frame_index``,
        ``episode_index``, ``index``, ``task_index``). Video, image and
        string features are skipped, with a note in
        ``metadata["skipped_features"]``. ``"FEATURE=STREAM"`` names the
        stream (``"observation.state=position"``: a library stores
        primitives of a ``position`` stream).
    progress : bool, default=False
        A tqdm bar over the episodes.

    Returns
    -------
    list of Demonstration
        One per episode, with streams named as the features (for example
        ``observation.state`` and ``action``) and ``t = frame_index / fps``.
        Metadata: ``source``, ``format`` (``"lerobot"``),
        ``codebase_version``, ``episode``, ``label`` (the episode's task),
        ``tasks`` (all its tasks), ``fps``, ``robot_type``, ``column_names``
        (per feature, when the dataset names them) and ``skipped_features``.

    Raises
    ------
    ImportError
        Without ``pyarrow``: ``pip install skillbank[lerobot]``.
    FormatError
        A folder that is not a LeRobot dataset, an unsupported version, a
        missing or corrupt file, or an episode whose data disagree with the
        index.
    ValueError
        A bad ``episodes`` or ``features``.

    Examples
    --------
    >>> demos = read_lerobot("my_dataset", episodes="0:2")  # doctest: +SKIP
    >>> demos[0].stream_names, demos[0].metadata["label"]  # doctest: +SKIP
    (['observation.state', 'action'], 'pick up the cube')
    """
    try:
        import pyarrow.parquet as pq  # optional extra (skillbank[lerobot])
    except ImportError:
        raise _missing_pyarrow() from None
    root = Path(path)
    if not root.is_dir() or not os.path.lexists(root / LEROBOT_INFO):
        found = "no such file or folder" if not root.exists() else (
            "a file" if not root.is_dir() else f"a folder without {LEROBOT_INFO}")
        raise FormatError(root, f"expected a LeRobot dataset folder (holding {LEROBOT_INFO}), found {found}")
    info = _info(root)
    specs = info["features"]
    skipped = {k: str(v.get("dtype")) for k, v in specs.items()
               if isinstance(v, dict) and str(v.get("dtype")) in _NOT_NUMBERS}
    numeric = [k for k, v in specs.items()
               if k not in _BOOKKEEPING and k not in skipped and isinstance(v, dict)]
    renames = {}
    if features is not None:
        features = [features] if isinstance(features, str) else list(features)
        if not all(isinstance(f, str) for f in features):
            raise ValueError(f"features: expected names or 'FEATURE=STREAM' strings, got {features!r}")
        renames = dict(f.split("=", 1) for f in features if "=" in f)
        features = [f.split("=", 1)[0] for f in features]
        unknown = [f for f in features if f not in numeric]
        if unknown or not features:
            raise ValueError(f"features: expected names among {numeric}, got {unknown or features}")
        if any(not name.strip() for name in renames.values()) or \
                len({renames.get(f, f) for f in features}) < len(features):
            raise ValueError(f"features: expected one distinct, non-empty stream name per feature, got "
                             f"{[renames.get(f, f) for f in features]}")
        numeric = features
    if not numeric:
        raise FormatError(root, f"expected numeric features in {LEROBOT_INFO}, found "
                          f"[{summarise(map(repr, sorted(specs)))}]")
    index = _episodes(root, info, pq)
    tasks = _tasks(root, info, pq)
    chosen = select_episodes(episodes, index)
    widths = {k: check_shape(root, k, specs[k]) for k in numeric}
    common = {"source": str(root), "format": "lerobot", "codebase_version": info["codebase_version"],
              "fps": info["fps"], "robot_type": info.get("robot_type")}
    names = {k: n for k in numeric if (n := _feature_names(specs[k])) is not None and len(n) == widths[k]}
    if names:
        common["column_names"] = names
    if skipped:
        common["skipped_features"] = skipped
    cache = {}  # v3 data files hold many episodes: read each once, while its episodes are read
    demos = []
    for ep in tqdm(chosen, desc="reading episodes", unit="episode", disable=not progress, leave=False):
        demos.append(_episode(root, info, index[ep], ep, numeric, widths, tasks, common, cache, pq))
    if renames:
        demos = [Demonstration(d.t, {renames.get(k, k): v for k, v in d.streams.items()}, d.metadata)
                 for d in demos]
    return demos


def _episode(root, info, row, ep, numeric, widths, tasks, common, cache, pq) -> Demonstration:
    where = f"episode {ep}"
    # The template's fields were checked (names, widths) with info.json, the indices with the episodes index.
    if _version(info) == "v2":
        rel = format_template(root, info["data_path"], where, episode_index=ep,
                              episode_chunk=ep // info.get("chunks_size", 1000))
    else:
        rel = format_template(root, info["data_path"], where, chunk_index=row["data/chunk_index"],
                              file_index=row["data/file_index"])
    if rel not in cache:
        file = _member(root, rel, what="data file")
        if file is None:
            raise FormatError(root, f"{where}: expected data file '{rel}', found none")
        cache.clear()
        table = _parquet(root, file, pq, f"{where}: corrupt data file '{rel}'")
        with reading(root, f"{where}: corrupt data file '{rel}'"):
            cache[rel] = (table, _rows_by_episode(table))
    with reading(root, f"{where}: corrupt data file '{rel}'"):
        table, rows = cache[rel]
        if rows is not None:
            chosen = rows.get(ep, (0, 0))
            table = table.slice(chosen[0], chosen[1] - chosen[0]) if isinstance(chosen, tuple) else \
                table.take(chosen)
        missing = [c for c in numeric if c not in table.column_names]
        if missing:
            raise FormatError(root, f"{where}: expected columns {missing} in '{rel}', found "
                              f"[{summarise(map(repr, table.column_names))}]")
        n = table.num_rows
        if "length" in row and int(row["length"]) != n:
            raise FormatError(root, f"{where}: the episodes index says {int(row['length'])} frames, "
                              f"'{rel}' holds {n}")
        if n == 0:
            raise FormatError(root, f"{where}: '{rel}' holds no frames")
        streams = {k: _numbers(root, table.column(k), n, widths[k], f"{where}: column {k!r}")
                   for k in numeric}
        frames = (np.asarray(table.column("frame_index").to_numpy(zero_copy_only=False), dtype=float)
                  if "frame_index" in table.column_names else np.arange(n, dtype=float))
        task_index = (table.column("task_index")[0].as_py() if "task_index" in table.column_names else None)
    t, *values, _ = check_clock(root, frames / float(info["fps"]), *streams.values(),
                                where=f"{where} (clock 'frame_index')")
    labels = list(row.get("tasks") or []) or ([tasks[task_index]] if task_index in tasks else [])
    metadata = {**common, "episode": ep}
    if labels:
        # "task": what the episode shows, which a library takes as its primitives' label (Library.add_files).
        metadata.update(label=labels[0], task=labels[0], tasks=labels)
    with reading(root, f"invalid {where}"):
        return Demonstration(t - t[0], dict(zip(streams, values, strict=True)), metadata)
