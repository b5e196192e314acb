"""Reading several files: a folder of trajectories, or a list of files holding one path each."""

from __future__ import annotations

from pathlib import Path

from tqdm import tqdm

from ..core import Demonstration
from ._confine import check_input_file
from ._detect import load

__all__ = ["load_folder", "load_positions", "TRAJECTORY_SUFFIXES"]

TRAJECTORY_SUFFIXES = (".csv", ".txt", ".npz")
_PROGRESS_FROM = 20  # files; fewer load too fast for a progress bar to help


def load_folder(folder, *, progress: bool = True, repair_time=None):
    """Load every trajectory file (``.csv``, ``.txt``, ``.npz``) of ``folder`` in sorted name order.

    ``repair_time`` is :func:`~skillbank.io.load_all`'s.

    Returns
    -------
    names : list of str
    demos : list of Demonstration

    Examples
    --------
    >>> names, demos = load_folder("lasa_csv/")  # doctest: +SKIP
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"input: expected a folder of trajectory files, got {str(folder)!r}")
    files = sorted(f for f in folder.iterdir()
                   if f.is_file() and not f.name.startswith(".") and f.suffix.lower() in TRAJECTORY_SUFFIXES)
    if not files:
        raise ValueError(f"input: expected trajectory files ({', '.join(TRAJECTORY_SUFFIXES)}) in folder "
                         f"{str(folder)!r}, found none")
    bar = tqdm(files, desc="loading", unit="file", leave=False,
               disable=not progress or len(files) < _PROGRESS_FROM)
    return [f.name for f in files], [load(f, repair_time=repair_time) for f in bar]


def load_positions(paths, *, repair_time=None, every_stream: bool = False,
                   pose_of=None) -> list[Demonstration]:
    """Load each file as a Demonstration whose ``"position"`` stream is the one to work on.

    The file's ``position`` stream is taken, or its only stream (renamed
    ``position``). ``repair_time`` is :func:`~skillbank.io.load_all`'s.

    Parameters
    ----------
    paths : sequence of str or path-like
    repair_time : str, optional
    every_stream : bool, default=False
        Keep the file's other streams (orientation, gripper, ...) and its
        metadata too, as an edit that carries them along needs; otherwise the
        result holds ``position`` alone and ``{"source": path}``.
    pose_of : str, optional
        The point of the robot the poses are of, where a file does not say
        (:func:`~skillbank.io.load_all`'s ``reader_options["pose_of"]``).

    Raises
    ------
    ValueError
        For a missing or unreadable file, a file with several streams none of
        them ``position``, or files of different dimensions.

    Examples
    --------
    >>> load_positions(["demo.csv"])[0].stream_names  # doctest: +SKIP
    ['position']
    """
    demos = []
    for path in paths:
        path = Path(path)
        if not path.exists():
            raise ValueError(f"input: no such file: {str(path)!r}")
        check_input_file(path, name="input")  # a FIFO or a device would block the reader
        demo = load(path, repair_time=repair_time,
                    reader_options=None if pose_of is None else {"pose_of": pose_of})
        if "position" in demo.streams:
            name = "position"
        elif len(demo.streams) == 1:
            name = demo.stream_names[0]
        else:
            raise ValueError(f"input: {str(path)!r} has streams {demo.stream_names} and none is 'position'; "
                             "write the one to edit as a single-stream file")
        Y = demo[name]
        if demos and Y.shape[1] != demos[0]["position"].shape[1]:
            raise ValueError(f"input: {str(path)!r} has {Y.shape[1]} dimensions, but "
                             f"{str(paths[0])!r} has {demos[0]['position'].shape[1]}")
        if every_stream:
            streams = {("position" if k == name else k): v for k, v in demo.streams.items()}
            demos.append(Demonstration(demo.t, streams, demo.metadata))
        else:
            demos.append(Demonstration(demo.t, {"position": Y}, {"source": str(path)}))
    return demos
