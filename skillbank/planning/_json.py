"""JSON documents a user hands the planner (scenes, bindings): nesting bounded, every value's type checked.

A scene needs four levels of nesting (scene, ``objects``, an object, its
``position``). :data:`MAX_JSON_DEPTH` bounds it well above that and is
checked **before** anything walks the structure: on the text before it is
parsed (Python's JSON reader recurses, and a few kilobytes of ``[`` would end
in a ``RecursionError``), and on a ``dict`` handed to the API (which may even
contain itself). The checks of single values name the key path
(``objects['b1'].position[2]``), say what was expected and describe what was
found in JSON's own terms (``true``, ``null``, a string, a list).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..core._validation import MAX_MAGNITUDE, _digits

__all__ = ["MAX_JSON_DEPTH", "check_depth", "load_json", "describe", "short", "number", "numbers",
           "text_depth"]

#: Deepest nesting of lists and objects accepted in a scene (a scene needs 4; deeper is never a scene).
MAX_JSON_DEPTH = 16
_OPEN, _CLOSE = np.frombuffer(b"[{", np.uint8), np.frombuffer(b"]}", np.uint8)
_CHUNK = 2 ** 20


def short(value, limit: int = 40) -> str:
    """``repr`` of a string cut to ``limit`` characters, so that a message stays one short line."""
    text = str(value)
    return repr(text if len(text) <= limit else text[:limit - 3] + "...")


def describe(value) -> str:
    """What a JSON value is, in JSON's terms: ``true``, ``null``, ``the number 5``, ``a list of 2 items``."""
    if value is None:
        return "null"
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        number = int(value)
        return f"the number {number}" if abs(number) < 10 ** 20 else f"an integer of {_digits(number)}"
    if isinstance(value, (float, np.floating)):
        text = "NaN" if np.isnan(value) else "Infinity" if value > 0 and np.isinf(value) else \
            "-Infinity" if np.isinf(value) else repr(float(value))
        return f"the number {text}"
    if isinstance(value, str):
        return f"the string {short(value)}"
    if isinstance(value, (list, tuple, np.ndarray)):
        return f"a list of {len(value)} item(s)"
    if isinstance(value, dict):
        return "an object"
    return f"a {type(value).__name__}"


def text_depth(data, name: str) -> None:
    """ValueError when JSON ``data`` (bytes or str) nests lists and objects deeper than MAX_JSON_DEPTH.

    Brackets inside strings do not count. One vectorised pass in chunks of
    1 MiB (a quote is escaped after an odd run of backslashes; a bracket is
    inside a string after an odd number of unescaped quotes), so time and
    memory are linear in the file for any content. JSON strings hold no raw
    newline, so the line reported is the file's.
    """
    raw = data.encode("utf-8", "surrogatepass") if isinstance(data, str) else bytes(data)
    codes = np.frombuffer(raw, np.uint8)
    run, quotes, level = 0, 0, 0  # carried across chunks: backslash run, quote parity, depth
    for start in range(0, codes.size, _CHUNK):
        part = codes[start:start + _CHUNK]
        index = np.arange(part.size)
        slash = part == ord("\\")
        last = np.maximum.accumulate(np.where(slash, -1, index))  # last non-backslash up to each byte
        ending = index - last + np.where(last < 0, run, 0)  # backslashes ending at each byte
        before = np.concatenate(([run], ending[:-1]))
        quote = (part == ord('"')) & (before % 2 == 0)
        inside = (quotes + np.cumsum(quote)) % 2 == 1
        step = (np.isin(part, _OPEN).astype(np.int64) - np.isin(part, _CLOSE)) * ~inside
        depth = level + np.cumsum(step)
        if depth.max() > MAX_JSON_DEPTH:
            at = start + int(np.argmax(depth > MAX_JSON_DEPTH))
            line = raw.count(b"\n", 0, at) + 1
            raise ValueError(f"{name}: expected JSON nested at most {MAX_JSON_DEPTH} levels deep (a scene "
                             f"needs 4), got deeper nesting at line {line}")
        run, quotes, level = int(ending[-1]), int(quotes + quote.sum()) % 2, int(depth[-1])


def check_depth(doc, name: str) -> None:
    """ValueError when a parsed document (lists, tuples, dicts) nests deeper than :data:`MAX_JSON_DEPTH`.

    Iterative, and each container is walked again only when reached deeper
    than before: a structure that contains itself is refused by depth, and a
    list shared by several keys costs no more than its copies would.
    """
    deepest: dict = {}
    stack = [(doc, 1)]
    while stack:
        value, depth = stack.pop()
        if isinstance(value, dict):
            children = list(value.values())
        elif isinstance(value, (list, tuple)):
            children = value
        else:
            continue
        if depth > MAX_JSON_DEPTH:
            raise ValueError(f"{name}: expected lists and objects nested at most {MAX_JSON_DEPTH} levels "
                             "deep (a scene needs 4, a binding 3), got deeper nesting (or a structure that "
                             "contains itself)")
        if deepest.get(id(value), 0) >= depth:
            continue
        deepest[id(value)] = depth
        stack.extend((child, depth + 1) for child in children)


def read_bounded(path: Path, name: str, max_bytes: int, *, kind: str = "a JSON file") -> bytes:
    """The bytes of file ``path``, at most ``max_bytes`` of them (more is refused before it is held)."""
    if not path.is_file():
        raise ValueError(f"{name}: expected {kind}, got {str(path)!r}, which is not a file")
    with path.open("rb") as fh:
        data = fh.read(max_bytes + 1)
    if len(data) > max_bytes:
        raise ValueError(f"{name}: expected a file of at most {max_bytes} bytes, got a larger one "
                         f"({str(path)!r})")
    return data


def utf8(data: bytes, name: str) -> str:
    """``data`` decoded as UTF-8; one line naming ``name`` and the byte where it is not."""
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ValueError(f"{name}: expected UTF-8 text, got {exc.reason} at byte {exc.start}") from None


def load_json(path: Path, name: str, max_bytes: int):
    """The JSON document of file ``path``: at most ``max_bytes``, nesting bounded, one-line errors."""
    return parse_json(read_bounded(path, name, max_bytes), f"{name} {str(path)!r}")


def parse_json(data, name: str):
    """The JSON document of ``data`` (bytes or str): nesting bounded, one-line errors naming ``name``."""
    text = utf8(data, name) if isinstance(data, bytes) else data
    text_depth(data, name)
    try:
        return json.loads(text)
    except (ValueError, RecursionError) as exc:  # JSONDecodeError, or an integer literal of > 4300 digits
        raise ValueError(f"{name}: expected JSON, got {' '.join(str(exc).split())[:160]}") from None


def number(value, where: str) -> float:
    """A JSON number (not a boolean) that is finite and within ``MAX_MAGNITUDE``, as a float."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{where}: expected a number, got {describe(value)}")
    if isinstance(value, (int, np.integer)):
        if abs(int(value)) > MAX_MAGNITUDE:
            raise ValueError(f"{where}: expected a number of magnitude at most {MAX_MAGNITUDE:g}, got "
                             f"{describe(value)}")
        return float(value)
    if not np.isfinite(value):
        why = " (a literal beyond float64's range, such as 1e400, reads as one)" if np.isinf(value) else ""
        raise ValueError(f"{where}: expected a finite number, got {describe(value)}{why}")
    if abs(value) > MAX_MAGNITUDE:
        raise ValueError(f"{where}: expected a number of magnitude at most {MAX_MAGNITUDE:g}, got "
                         f"{describe(value)}")
    return float(value)


def numbers(value, where: str, n: int | None = None) -> np.ndarray:
    """A list of ``n`` (or at least one) JSON numbers as a float array; each item named ``where[k]``."""
    if isinstance(value, np.ndarray) and value.ndim == 1:
        value = value.tolist()
    want = f"{n} numbers" if n is not None else "at least one number"
    if not isinstance(value, (list, tuple)):
        raise ValueError(f"{where}: expected a list of {want}, got {describe(value)}")
    if (n is not None and len(value) != n) or not value:
        raise ValueError(f"{where}: expected {want}, got {len(value)}")
    return np.array([number(v, f"{where}[{k}]") for k, v in enumerate(value)], dtype=float)
