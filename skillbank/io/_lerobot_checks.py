"""Checks of a LeRobot dataset's metadata, before anything is formatted, allocated or opened.

``meta/info.json`` and the episodes index are the dataset's own words about
itself, so each field is checked for its type and range first: a template
field ``{episode_index:>1000000000}`` would otherwise build a path of a
gigabyte, an ``episode_index`` of ``1e999`` or an ``fps`` of 400 digits fail
inside Python's number conversion, and a ``data_path`` of ``"../x"`` read a
file outside the dataset (:func:`~skillbank.io._confine.inside` refuses that
when the path is opened).
"""

from __future__ import annotations

import math
import re
import string

from ..core._validation import summarise
from ._errors import FormatError

__all__ = ["MAX_FPS", "MAX_INDEX", "MAX_FIELD_WIDTH", "MAX_TEMPLATE", "check_fps", "check_index",
           "check_template", "format_template", "check_shape", "check_rows", "check_task_rows"]

#: The highest frame rate read (Hz): no camera or robot logs a million frames a second.
MAX_FPS = 1e6
#: Episode, chunk, file and task indices are integers in ``[0, MAX_INDEX]``.
MAX_INDEX = 10**12
#: The widest a template field may format (``{episode_index:06d}`` is 6): a path is short.
MAX_FIELD_WIDTH = 64
#: The longest ``data_path`` template (characters), about a file-system path's limit.
MAX_TEMPLATE = 1024
# [[fill]align][sign][z][#][0][width][grouping][.precision][type], as Python's format mini-language.
_SPEC = re.compile(r"^(?:.?[<>=^])?[+\- ]?z?#?0?(?P<width>\d*)[,_]?(?:\.(?P<precision>\d*))?"
                   r"[bcdeEfFgGnosxX%]?$")
_FIELDS = {"v2": ("episode_chunk", "episode_index"), "v3": ("chunk_index", "file_index")}
INFO = "meta/info.json"


def _short(value, width: int, raw: bool = False) -> str:
    """``repr(value)`` (``value`` itself if ``raw``) cut to ``width`` characters: a field may be long."""
    try:
        text = value if raw else repr(value)
    except ValueError:  # an int beyond Python's digit limit
        return type(value).__name__
    return text if len(text) <= width else text[:width - 3] + "..."


def _is_int(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def check_fps(root, fps) -> float:
    """The frame rate as a float in ``(0, MAX_FPS]``, else a FormatError."""
    if _is_int(fps) or isinstance(fps, float):
        if 0 < fps <= MAX_FPS:  # compared before float(): an int of 400 digits has no float
            return float(fps)
    raise FormatError(root, f"expected 'fps' in {INFO} to be a number in (0, {MAX_FPS:g}] frames per second, "
                      f"found {_short(fps, 40)}")


def check_index(root, value, what: str) -> int:
    """An index (``episode_index``, ``chunks_size``, ...) as an int in ``[0, MAX_INDEX]``."""
    if _is_int(value) and 0 <= value <= MAX_INDEX:
        return value
    raise FormatError(root, f"expected {what} to be an integer in [0, {MAX_INDEX}], found "
                      f"{_short(value, 40)}")


def check_template(root, template, version: str) -> str:
    """``data_path``: a string of at most MAX_TEMPLATE characters whose fields are the layout's, each narrow.

    Checked with :class:`string.Formatter` before anything is formatted:
    only the layout's field names (v2.1: ``episode_chunk``, ``episode_index``;
    v3.0: ``chunk_index``, ``file_index``), no attribute or item access, no
    conversion, and widths and precisions of at most MAX_FIELD_WIDTH.
    """
    if not isinstance(template, str):
        raise FormatError(root, f"expected 'data_path' in {INFO} to be a string (a path template), found "
                          f"{type(template).__name__} {_short(template, 40)}")
    if len(template) > MAX_TEMPLATE:
        raise FormatError(root, f"expected 'data_path' in {INFO} of at most {MAX_TEMPLATE} characters, found "
                          f"{len(template)}")
    names = _FIELDS[version]
    try:
        fields = [(name, spec, conv) for _, name, spec, conv in string.Formatter().parse(template)
                  if name is not None]
    except ValueError as exc:
        raise FormatError(root, f"'data_path' {_short(template, 60)} in {INFO} is not a "
                          f"valid template: {exc}") from None
    for name, spec, conv in fields:
        field = "{" + name + ("!" + conv if conv else "") + (":" + spec if spec else "") + "}"
        shown = _short(field, 40, raw=True)
        if name not in names or conv is not None:
            raise FormatError(root, f"'data_path' in {INFO}: expected fields among "
                              f"{['{' + n + '}' for n in names]}, found {shown}")
        match = _SPEC.match(spec)
        if match is None:
            raise FormatError(root, f"'data_path' in {INFO}: field {shown} has a format spec that is not a "
                              "plain width and type (like '06d')")
        for part in ("width", "precision"):
            digits = match.group(part) or "0"
            if len(digits) > 3 or int(digits) > MAX_FIELD_WIDTH:
                raise FormatError(root, f"'data_path' in {INFO}: field {shown} asks for a {part} of "
                                  f"{_short(digits, 20, raw=True)} characters; expected at most "
                                  f"{MAX_FIELD_WIDTH} (LeRobot writes widths like 03d and 06d)")
    return template


def format_template(root, template: str, where: str, **values) -> str:
    """The data file of an episode: the checked template with ``values`` put in."""
    try:
        return template.format(**values)
    except (KeyError, ValueError, IndexError, TypeError) as exc:
        raise FormatError(root, f"{where}: cannot locate its data file from data_path {template!r} "
                          f"({type(exc).__name__}: {exc})") from None


def check_shape(root, name: str, spec: dict) -> int:
    """The number of values per frame of feature ``name``: its ``shape``, a list of non-negative ints."""
    shape = spec.get("shape", [1])
    if not isinstance(shape, list) or not shape or len(shape) > 8 or not all(
            _is_int(s) and 0 <= s <= MAX_INDEX for s in shape):
        raise FormatError(root, f"expected 'shape' of feature {name!r} in {INFO} to be a list of 1 to 8 "
                          f"non-negative integers like [6], found {_short(shape, 40)}")
    return math.prod(shape) or 1


def check_rows(root, rows, version: str) -> dict[int, dict]:
    """The episodes index as ``{episode_index: row}``, each field it uses checked."""
    out = {}
    for k, row in enumerate(rows):
        if not isinstance(row, dict) or "episode_index" not in row:
            raise FormatError(root, f"expected an 'episode_index' in every row of the episodes index, "
                              f"row {k} has {_short(row, 60)}")
        ep = check_index(root, row["episode_index"], f"'episode_index' of row {k} of the episodes index")
        if "length" in row:
            check_index(root, row["length"], f"the 'length' of episode {ep}")
        tasks = row.get("tasks")
        if tasks is not None and not (isinstance(tasks, list) and all(isinstance(t, str) for t in tasks)):
            raise FormatError(root, f"expected the 'tasks' of episode {ep} to be a list of strings, found "
                              f"{_short(tasks, 40)}")
        if version == "v3":
            for key in ("data/chunk_index", "data/file_index"):
                if key not in row:
                    raise FormatError(root, f"expected {key!r} for episode {ep} in the episodes index, found "
                                      f"[{summarise(map(repr, sorted(row)))}]")
                check_index(root, row[key], f"{key!r} of episode {ep}")
        if ep in out:
            raise FormatError(root, f"episode {ep} is listed twice in the episodes index")
        out[ep] = row
    return out


def check_task_rows(root, rows, where: str) -> dict[int, str]:
    """``{task_index: task}`` from rows that each need a ``task_index`` (an int) and a ``task`` (a string)."""
    out = {}
    for k, row in enumerate(rows):
        if not isinstance(row, dict) or "task_index" not in row or not isinstance(row.get("task"), str):
            keys = sorted(row) if isinstance(row, dict) else type(row).__name__
            raise FormatError(root, f"expected 'task_index' and 'task' (a string) in every row of {where}, "
                              f"row {k} has {keys}")
        out[check_index(root, row["task_index"], f"'task_index' of row {k} of {where}")] = row["task"]
    return out
