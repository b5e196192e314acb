"""Fuzz of scene parsing (issue 23, item 8): any JSON value at any key of a valid scene.

The only outcomes are a parsed scene or a ``ValueError`` whose message is one line and starts with
the key it is about: the key replaced, a key inside it (``position[1]``), the object that holds it
(``start`` when ``start.joints`` and ``start.position`` are both given), or, when an object was
replaced, the fact that names it (``goal[0]: '(pressed b1)' names 'b1', which is not an object``).
"""

from __future__ import annotations

import copy
import json
import os

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from skillbank.planning import Scene, scene_from_dict

BASE = {
    "objects": {"b1": {"type": "button", "position": [0.1, -0.5, 0.15], "orientation": [0, 1, 0, 0]},
                "b2": {"type": "button", "position": [0.3, -0.5, 0.15]}},
    "obstacles": ["sphere:0.0,-0.5,0.2,0.03", "box:0,0,0,1,1,1"],
    "init": ["(free b1)", "(free b2)"],
    "goal": ["(pressed b1)"],
    "start": {"position": [0.0, -0.45, 0.4], "orientation": [0, 1, 0, 0], "gripper": 1.0},
}
PATHS = [
    ("objects",), ("objects", "b1"), ("objects", "b1", "type"), ("objects", "b1", "position"),
    ("objects", "b1", "position", 1), ("objects", "b1", "orientation"), ("objects", "b1", "orientation", 3),
    ("objects", "b2", "orientation"), ("obstacles",), ("obstacles", 1), ("init",), ("init", 0), ("goal",),
    ("goal", 0), ("start",), ("start", "position"), ("start", "position", 2), ("start", "orientation"),
    ("start", "joints"), ("start", "gripper"), ("domain",),
]

HUGE = st.sampled_from([10 ** 30, -10 ** 101, 10 ** 400, 2 ** 63])
SCALARS = (st.none() | st.booleans() | st.integers(-10, 10) | HUGE | st.floats(allow_nan=True)
           | st.text(max_size=8))
VALUES = st.recursive(SCALARS, lambda inner: st.lists(inner, max_size=4)
                      | st.dictionaries(st.text(max_size=6), inner, max_size=3), max_leaves=8)
# Values a scene could hold, so that replacing a key also gives valid scenes and near misses.
PLAUSIBLE = st.one_of(
    st.lists(st.floats(-2.0, 2.0), min_size=2, max_size=5),
    st.sampled_from([[0, 0, 0, 1], [0, 0, 0, 2], [0.1, 0.2, 0.3], "button", "(free b2)", "(pressed b3)",
                     "(pressed ?x)", "sphere:0,0,0,0.1", "sphere:0,0,0.1", "box:0,0,0,1,1,1", ["(free b1)"],
                     {"type": "button"}, {"type": "Button", "position": [1, 2, 3]}, {"b1": {"type": "t"}},
                     {"joints": [0.0] * 6}, {"position": [0, 0, 0]}, [], {}, "", "d.pddl"]),
)
FUZZ = settings(max_examples=int(os.environ.get("SKILLBANK_FUZZ_EXAMPLES", "300")), deadline=None,
                suppress_health_check=[HealthCheck.too_slow])


def _name(path) -> str:
    """How messages name a key: ``objects['b1'].position[1]``, ``start.gripper``, ``goal[0]``."""
    out = path[0]
    for k, part in enumerate(path[1:], 1):
        if isinstance(part, int):
            out += f"[{part}]"
        elif path[0] == "objects" and k == 1:
            out += f"[{part!r}]"
        else:
            out += f".{part}"
    return out


def _replace(doc, path, value):
    doc = copy.deepcopy(doc)
    holder = doc
    for part in path[:-1]:
        holder = holder[part]
    holder[path[-1]] = value
    return doc


def _about(head: str, path) -> bool:
    name = _name(path)
    ancestors = {_name(path[:k]) for k in range(1, len(path))}
    if head == name or head.startswith(name + "[") or head.startswith(name + ".") or head in ancestors:
        return True
    # a replaced object (or its name) leaves the facts that name it naming nothing
    return path[0] == "objects" and head.split("[")[0] in ("init", "goal")


@FUZZ
@given(st.sampled_from(PATHS), VALUES | PLAUSIBLE)
def test_any_value_at_any_key_is_a_scene_or_one_line_naming_the_key(path, value):
    doc = _replace(BASE, path, value)
    try:
        scene = scene_from_dict(doc)
    except ValueError as exc:
        message = str(exc)
        assert "\n" not in message and len(message) < 400, message
        head = message.split(": ", 1)[0]
        assert _about(head, path), (path, message)
        return
    assert isinstance(scene, Scene)
    for obj in scene.objects.values():  # whatever was read is finite numbers of the right shapes
        assert obj.position is None or (obj.position.shape == (3,) and np.isfinite(obj.position).all())
        assert obj.orientation is None or abs(np.linalg.norm(obj.orientation) - 1.0) < 1e-12


@FUZZ
@given(st.sampled_from(PATHS), VALUES)
def test_the_same_value_read_from_a_file_gives_the_same_outcome(tmp_path_factory, path, value):
    """A scene file is the dict's JSON: reading it gives the same scene or the same message."""
    from skillbank.planning import load_scene  # the file reader beside the dict reader

    doc = _replace(BASE, path, value)
    try:
        text = json.dumps(doc)
    except ValueError:  # an int of more than 4300 digits cannot be written: not a file to read
        return
    file = tmp_path_factory.mktemp("fuzz") / "scene.json"
    file.write_text(text)
    outcomes = []
    for read in (lambda: scene_from_dict(json.loads(text)), lambda: load_scene(file)):
        try:
            outcomes.append(sorted(read().objects))
        except ValueError as exc:
            outcomes.append(str(exc))
    if path == ("domain",) and isinstance(value, str):
        return  # a file name: from a dict there is no folder, from a file there is one
    assert outcomes[0] == outcomes[1], (path, outcomes)


def _depth(value) -> int:
    if isinstance(value, list):
        return 1 + max((_depth(v) for v in value), default=0)
    if isinstance(value, dict):
        return 1 + max((_depth(v) for v in value.values()), default=0)
    return 0


TRICKY = st.text(alphabet='[]{}"\\\n a', max_size=6)  # brackets, quotes and backslashes inside strings
NESTED = st.recursive(TRICKY | st.integers() | st.none(), lambda inner: st.lists(inner, max_size=3)
                      | st.dictionaries(TRICKY, inner, max_size=3), max_leaves=30)


@FUZZ
@given(NESTED, st.booleans(), st.sampled_from([1, 2, 3, 7, 2 ** 20]))
def test_the_depth_read_from_the_text_is_the_depth_of_the_document(value, ascii_only, chunk):
    """The text check refuses exactly the documents deeper than the bound, for any strings inside."""
    import skillbank.planning._json as reader  # its bound and chunk size, set for the property

    text = json.dumps(value, ensure_ascii=ascii_only)
    depth = _depth(value)
    saved = reader.MAX_JSON_DEPTH, reader._CHUNK
    try:
        reader._CHUNK = chunk
        for bound in {max(depth - 1, 0), depth, depth + 1}:
            reader.MAX_JSON_DEPTH = bound
            try:
                reader.text_depth(text, "scene")
                refused = False
            except ValueError:
                refused = True
            assert refused == (depth > bound), (text, bound)
    finally:
        reader.MAX_JSON_DEPTH, reader._CHUNK = saved


TOKENS = st.sampled_from(["(", ")", "(", ")", ":action", ":parameters", ":precondition", ":effect", "and",
                          "not", "or", "forall", "-", "?b", "?c", "b1", "button", "define", "domain",
                          "(domain", ":types", ":predicates", ":requirements", ";", "\n", "3x", "press",
                          "pressed"])


@FUZZ
@given(st.lists(TOKENS, max_size=40), st.booleans())
def test_any_pddl_token_soup_is_an_action_or_one_line(tokens, as_domain):
    """parse_action and parse_domain: a parsed schema whose atoms all read, or one ValueError line."""
    from skillbank.planning import parse_action, parse_domain  # the PDDL readers

    text = " ".join(tokens)
    try:
        if as_domain:
            domain = parse_domain(text)
            for action in domain.actions.values():
                action.atoms()
        else:
            parse_action(text).atoms()
    except ValueError as exc:
        message = str(exc)
        assert "\n" not in message and len(message) < 400, message
        assert message.startswith(("action", "domain")), message
