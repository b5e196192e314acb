"""Robot descriptions read confined to their folder: MuJoCo compiles them from memory.

MuJoCo's parsers read files themselves, with rules of their own (includes
tried from two folders, ``meshdir``/``texturedir``/``assetdir`` applied in
document order, ``strippath``), so checking a file and then handing MuJoCo its
path lets MuJoCo read what the check never saw. Here skillbank reads every
file: the main URDF or MJCF and each include (each parsed once, no DOCTYPE or
ENTITY), then every file an element names, resolved with MuJoCo 3.3.7's rules
but only inside the description's folder, each the bytes of a regular file.
MuJoCo gets the expanded XML, every file attribute rewritten to a flat name,
and a dictionary of those names' bytes (its virtual file system): no path
reaches it. The bounds (``_description_bounds``) are checked before the work.
"""

from __future__ import annotations

import math
import os
import re
import xml.etree.ElementTree as ET
import xml.parsers.expat
from collections import deque
from typing import NamedTuple

from ._description_bounds import (
    BOUNDS,
    Budget,
    check_png,
    description_bound,
    inside,
    over_bound,
    read_regular_file,
)

__all__ = ["Described", "read_description"]


class Described(NamedTuple):
    """A description read into memory: what MuJoCo compiles, and nothing that names a path.

    Attributes
    ----------
    kind : str
        ``"urdf"`` or ``"mjcf"``.
    xml : str
        The description with its includes expanded and every file attribute a key of ``assets``.
    assets : dict of str to bytes
        The files' bytes by the flat names the XML uses.
    files : tuple of str
        The real paths read, the main file first.
    """

    kind: str
    xml: str
    assets: dict
    files: tuple


#: MJCF elements whose files MuJoCo reads: attribute -> the compiler folder it lies under (3.3.7: meshes,
#: skins and height fields under ``meshdir``, every texture file under ``texturedir``).
_MJCF_FILES = {"mesh": {"file": "mesh"}, "skin": {"file": "mesh"}, "hfield": {"file": "mesh"},
               "texture": {a: "texture" for a in ("file", "fileright", "fileleft", "fileup", "filedown",
                                                  "filefront", "fileback")}}
#: Elements that make many elements from one, read other models or load code: not part of an arm.
_REFUSED = ("replicate", "composite", "flexcomp", "attach", "model", "plugin", "extension", "instance")
#: Sections that only size memory (``size``: arenas, user data; ``custom``: numeric and text data).
_DROPPED = ("size", "custom")
#: Attributes that hold names or keywords, not numbers.
_WORDS = frozenset("""name class childclass model link joint joint1 joint2 body body1 body2 site site1 site2
    geom geom1 geom2 parent child mesh material texture hfield tendon tendon1 tendon2 actuator objname refname
    objtype reftype target prefix content_type type plugin key mode meshname cranksite slidersite
    jointinparent""".split())
#: Deepest nesting read: MuJoCo's XML parser (tinyxml2) stops at 500, and the tree is written out again
#: recursively.
_DEPTH = 490
#: The tags counted as bodies, joints and geoms.
_COUNTED = {"mjcf": ("body", ("joint", "freejoint"), ("geom",)),
            "urdf": ("link", ("joint",), ("visual", "collision"))}
_NONFINITE = re.compile(r"[+-]?(nan|inf)", re.IGNORECASE)
#: What a value holding a non-finite number must contain: a word, a large exponent, a hex float or 309 digits.
_SUSPECT = re.compile(r"nan|inf|e[+-]?\d{3}|0x|\d{309}", re.IGNORECASE)


class _State:
    def __init__(self, main: str):
        self.main = main
        self.folder = os.path.dirname(main)
        self.budget = Budget()
        self.assets: dict[str, bytes] = {}
        self.flat: dict[str, str] = {}
        self.used: set[str] = set()
        self.files = [main]


def _shown(tag: str, attr: str) -> str:
    return f"<{tag}> {attr}"


def _nonfinite(token: str) -> bool:
    """Whether C's strtod, which MuJoCo reads numbers with, makes ``token`` a NaN or an infinity."""
    if _NONFINITE.match(token):  # nan, nan(...), inf, infinity, any case
        return True
    try:
        return math.isinf(float(token))  # 1e999
    except ValueError:
        pass
    try:
        return math.isinf(float.fromhex(token))
    except ValueError:
        return False
    except OverflowError:  # 0x1p99999
        return True


def _check_depth(root, path: str) -> None:
    stack = [(root, 1)]
    while stack:
        el, d = stack.pop()
        if d > _DEPTH:
            raise ValueError(f"robot description {path}: elements nested more than {_DEPTH} deep (MuJoCo's "
                             "XML parser reads 500)")
        stack.extend((c, d + 1) for c in el)


class _Scan:
    """expat's pass over one file before it is built into a tree: no DOCTYPE or ENTITY, and the depth
    and the counts of :data:`_COUNTED` within their bounds, stopping at the first element over."""

    def __init__(self, path: str):
        self.path, self.depth, self.counts, self.kind = path, 0, {}, None
        self.bounds = {key: description_bound(key) for key in ("ELEMENTS", "BODIES", "JOINTS", "GEOMS")}

    def declared(self, *_):
        raise ValueError(f"robot description {self.path}: declares a DOCTYPE or ENTITY, which MuJoCo's XML "
                         "parser reads differently; remove the declaration")

    def start(self, tag, _attrs):
        if self.kind is None:
            self.kind = "urdf" if tag.lower() == "robot" else "mjcf"
            body, joints, geoms = _COUNTED[self.kind]
            self.keys = {body: "BODIES", **dict.fromkeys(joints, "JOINTS"), **dict.fromkeys(geoms, "GEOMS")}
        self.depth += 1
        if self.depth > _DEPTH:
            raise ValueError(f"robot description {self.path}: elements nested more than {_DEPTH} deep "
                             "(MuJoCo's XML parser reads 500)")
        for key in (self.keys.get(tag), "ELEMENTS"):
            if key is not None:
                self.counts[key] = self.counts.get(key, 0) + 1
                if self.counts[key] > self.bounds[key]:
                    over_bound(self.path, self.counts[key], key, f"or more {BOUNDS[key][1]}")

    def end(self, _tag):
        self.depth -= 1


def _parse(data: bytes, path: str):
    """The tree of one file's bytes; a DOCTYPE or ENTITY (MuJoCo's parser reads them otherwise) is refused."""
    scan, parser = _Scan(path), xml.parsers.expat.ParserCreate()
    parser.StartDoctypeDeclHandler = parser.EntityDeclHandler = scan.declared
    parser.StartElementHandler, parser.EndElementHandler = scan.start, scan.end
    try:
        parser.Parse(data, True)
        root = ET.fromstring(data)
    except (xml.parsers.expat.ExpatError, ET.ParseError) as e:
        raise ValueError(f"robot description {path}: not well-formed XML ({e}); give a URDF or MJCF "
                         "file") from None
    for el in root.iter():
        for key, value in el.attrib.items():
            if key in _WORDS or key.lower().startswith("file") or not _SUSPECT.search(value):
                continue  # most values: one regular expression over the whole, not a loop over the numbers
            for token in value.split():
                if _nonfinite(token):
                    raise ValueError(f"robot description {path}: <{el.tag}> {key}={value[:60]!r} holds "
                                     f"{token!r}, not a finite number; give finite numbers")
    return root


def _locate(state: _State, path: str, shown: str, value: str, candidates: list[str]) -> str:
    """The real path of the first candidate that exists, in MuJoCo's order of trying them.

    A candidate outside the folder is refused, whether or not a later one would be found inside: MuJoCo
    would read it if it existed, and whether it exists is never looked at.
    """
    for candidate in candidates:
        if not inside(state.folder, candidate):
            raise ValueError(f"robot description {path}: {shown} {value!r} lies outside the description's "
                             f"folder {state.folder}; keep every file it names inside that folder")
        real = os.path.realpath(candidate)
        if os.path.exists(real):
            return real
    raise ValueError(f"robot description {path}: {shown} {value!r} is no file in the description's folder "
                     f"{state.folder}")


def _asset(state: _State, real: str, written: str, path: str, shown: str) -> str:
    """The flat name MuJoCo knows file ``real`` by (its written name, made unique); read once."""
    if real in state.flat:
        return state.flat[real]
    data = read_regular_file(real, path, shown, state.budget)
    check_png(data, path, shown)
    base = re.sub(r"[^A-Za-z0-9._-]", "_", _basename(written)) or "file"
    stem, ext = os.path.splitext(base)
    name, k = base, 0
    while name.lower() in state.used:  # unique whatever the case: a file system may ignore it
        k += 1
        name = f"{stem}_{k}{ext}"
    state.used.add(name.lower())
    state.flat[real] = name
    state.assets[name] = data
    state.files.append(real)
    return name


def _basename(value: str) -> str:
    return re.split(r"[/\\]", value)[-1]  # MuJoCo's strippath: either separator


def _stem(value: str) -> str:
    base = _basename(value)
    return base[:base.rfind(".")] if "." in base else base


def _check_dirs(state: _State, path: str, compiler) -> None:
    """A compiler folder (``meshdir``, ``texturedir``, ``assetdir``) outside the description's is refused."""
    for key in ("assetdir", "meshdir", "texturedir"):
        value = compiler.get(key)
        if value is not None and not inside(state.folder, os.path.join(state.folder, value)):
            raise ValueError(f"robot description {path}: {key} {value!r} lies outside the description's "
                             f"folder {state.folder}; keep every file it names inside that folder")


def _drop(root, tags) -> None:
    for parent in root.iter():
        for child in [c for c in parent if c.tag in tags]:
            parent.remove(child)


def _mjcf(state: _State, root) -> None:
    """Expand the includes (each file once) and rewrite every file an element names."""
    origin = {}  # element -> (the file it came from, that file's folder relative to the description's)
    included = {state.main}
    stack = [(root, state.main, "")]
    while stack:
        parent, source, folder = stack.pop()
        pending = deque((child, source, folder) for child in parent)
        children = []
        while pending:
            child, src, sub = pending.popleft()
            if child.tag.lower() != "include":
                origin[child] = (src, sub)
                children.append(child)
                stack.append((child, src, sub))
                continue
            value = child.get("file")
            if value is None or len(child):
                raise ValueError(f"robot description {src}: an <include> needs a file and no children")
            real = _locate(state, src, "<include> file", value,
                           [os.path.join(state.folder, value), os.path.join(state.folder, sub, value)])
            if real in included:
                raise ValueError(f"robot description {src}: <include> file {value!r} is included twice "
                                 "(MuJoCo includes a file once); include it in one place")
            included.add(real)
            over_bound(state.main, len(included) - 1, "INCLUDES")
            data = read_regular_file(real, src, f"<include> file {value!r}", state.budget)
            state.files.append(real)
            inner = _parse(data, real)
            where = os.path.relpath(os.path.dirname(real), state.folder)
            pending.extendleft((c, real, "" if where == "." else where) for c in reversed(list(inner)))
        parent[:] = children
    _check_depth(root, state.main)
    _count(state.main, root, *_COUNTED["mjcf"])
    for el in root.iter():
        if el.tag.lower() in _REFUSED:
            raise ValueError(f"robot description {origin.get(el, (state.main,))[0]}: <{el.tag}> is not "
                             "supported (skillbank reads an arm's bodies, joints and geoms); write what it "
                             "makes out")
    _drop(root, _DROPPED)
    dirs, strip = {"mesh": "", "texture": ""}, False
    # MuJoCo 3.3.7: each <compiler> in turn; its assetdir sets both folders, then meshdir and texturedir
    for el in root.iter():
        if el.tag.lower() != "compiler":
            continue
        _check_dirs(state, origin.get(el, (state.main,))[0], el)
        if el.get("assetdir") is not None:
            dirs["mesh"] = dirs["texture"] = el.get("assetdir")
        for key in ("mesh", "texture"):
            if el.get(f"{key}dir") is not None:
                dirs[key] = el.get(f"{key}dir")
        if el.get("strippath") in ("true", "false"):
            strip = el.get("strippath") == "true"
        for key in ("assetdir", "meshdir", "texturedir"):
            el.attrib.pop(key, None)
    for el in root.iter():
        _check_grid(origin.get(el, (state.main,))[0], el)
        for attr in [a for a in el.attrib if a.lower().startswith("file")]:
            src, sub = origin.get(el, (state.main, ""))
            shown = _shown(el.tag, attr)
            under = _MJCF_FILES.get(el.tag, {}).get(attr)
            if under is None:
                raise ValueError(f"robot description {src}: {shown} names a file MuJoCo would read that "
                                 "skillbank does not; remove it")
            value = el.get(attr)
            name = _basename(value) if strip else value
            candidates = [os.path.join(state.folder, dirs[under], name)]
            if sub and not strip:  # MuJoCo's second try: the including file's folder
                candidates.append(os.path.join(state.folder, sub, name))
            real = _locate(state, src, shown, value, candidates)
            el.set(attr, _asset(state, real, value, src, f"{shown} {value!r}"))
            if attr == "file" and el.get("name") is None:
                el.set("name", _stem(value))  # the name MuJoCo gives it, which the flat name may not keep


def _check_grid(path: str, el) -> None:
    """A texture made by MuJoCo (``builtin``) or a height field without a file is sized by its attributes:
    their pixels are bounded as an image's, before MuJoCo allocates them."""
    keys = {"texture": ("width", "height"), "hfield": ("nrow", "ncol")}.get(el.tag)
    if keys is None:
        return
    try:  # as a number, whatever its spelling ("4e4", "40000.5"): finite, the numbers' check has seen to it
        width, height = (int(float((el.get(k) or "0").split()[0])) for k in keys)
    except (ValueError, IndexError):
        return  # MuJoCo's own error says what is wrong
    faces = 6 if el.tag == "texture" and el.get("type") in ("cube", "skybox") else 1
    over_bound(path, abs(width * height) * faces, "PIXELS",
               f"pixels in <{el.tag} {keys[0]}={width} {keys[1]}={height}>")


def _urdf(state: _State, root) -> None:
    """Check the joints' limits; rewrite every mesh (the only file MuJoCo's URDF reader opens)."""
    path = state.main
    block = next((c for c in root if c.tag == "mujoco"), None)
    compiler = next((c for c in block if c.tag == "compiler"), None) if block is not None else None
    meshdir, strip, discard = "", True, True  # MuJoCo's URDF defaults: strippath, discardvisual
    if compiler is not None:  # MuJoCo reads the first <mujoco> block's first <compiler> only
        meshdir = compiler.get("meshdir", compiler.get("assetdir", ""))
        strip = compiler.get("strippath", "true") != "false"
        discard = compiler.get("discardvisual", "true") != "false"
    for el in root.iter():
        if el.tag.lower() == "compiler":
            _check_dirs(state, path, el)
            for key in ("assetdir", "meshdir", "texturedir"):
                el.attrib.pop(key, None)
    _drop(root, _DROPPED)
    if discard:  # MuJoCo would not build them: their meshes need not be read
        for link in root.iter("link"):
            for visual in link.findall("visual"):
                link.remove(visual)
    for joint in root.findall("joint"):
        _check_limit(path, joint)
    _count(path, root, *_COUNTED["urdf"])
    for el in root.iter():
        for attr in [a for a in el.attrib if a.lower().startswith("file")]:
            if el.tag != "mesh" or attr != "filename":
                del el.attrib[attr]  # a texture's file, say: MuJoCo's URDF reader reads none
                continue
            value = el.get(attr)
            written = re.sub(r"^(package|file)://", "", value)
            shown = "mesh"
            if not inside(state.folder, os.path.join(state.folder, meshdir, written)):
                raise ValueError(f"robot description {path}: {shown} {value!r} lies outside the "
                                 f"description's folder {state.folder}; keep every file it names inside that "
                                 "folder")
            name = _basename(value) if strip else value
            real = _locate(state, path, shown, value, [os.path.join(state.folder, meshdir, name)])
            el.set(attr, _asset(state, real, name, path, f"mesh {value!r}"))


def _check_limit(path: str, joint) -> None:
    limit = joint.find("limit")
    if limit is None:
        return
    name = joint.get("name", "")
    given = [limit.get(k) for k in ("lower", "upper")]
    if given.count(None) == 1 and joint.get("type") in ("revolute", "prismatic"):
        raise ValueError(f"robot description {path}: joint {name!r} has a <limit> with only "
                         f"{'lower' if given[0] is not None else 'upper'}; give both lower and upper")
    if None in given:
        return
    try:
        lower, upper = float(given[0]), float(given[1])
    except ValueError:
        raise ValueError(f"robot description {path}: joint {name!r} has a <limit> lower={given[0]!r} "
                         f"upper={given[1]!r}; give numbers") from None
    if lower > upper:
        raise ValueError(f"robot description {path}: joint {name!r} has its lower limit {lower:g} above its "
                         f"upper limit {upper:g}; give lower <= upper")


def _count(path: str, root, body: str, joints: tuple, geoms: tuple) -> None:
    """Refuse more elements, bodies, joints or geoms than the bounds, before MuJoCo parses any."""
    tags = [el.tag for el in root.iter()]
    over_bound(path, tags.count(body), "BODIES")
    over_bound(path, sum(tags.count(t) for t in joints), "JOINTS")
    over_bound(path, sum(tags.count(t) for t in geoms), "GEOMS")
    over_bound(path, len(tags), "ELEMENTS")


def read_description(path) -> Described:
    """Read a robot description and every file it names into memory, confined to its folder.

    Parameters
    ----------
    path : path-like
        The URDF or MJCF file; its folder (links followed) holds every file it names.

    Returns
    -------
    Described

    Raises
    ------
    ValueError
        One line naming the file and what is wrong: not URDF or MJCF, a DOCTYPE, a file outside the folder
        or not a regular file, a non-finite number, a URDF limit with lower above upper, or over a bound.
    """
    main = os.path.realpath(os.fspath(path))
    state = _State(main)
    root = _parse(read_regular_file(main, main, "the file", state.budget), main)
    kind = {"robot": "urdf", "mujoco": "mjcf"}.get(root.tag.lower())
    if kind is None:
        raise ValueError(f"robot description {main}: expected a URDF (<robot>) or MJCF (<mujoco>) document, "
                         f"got <{root.tag}>")
    (_urdf if kind == "urdf" else _mjcf)(state, root)
    for el in root.iter():  # nothing MuJoCo could open is left: every file attribute is an asset's name
        leftover = [a for a in el.attrib if a.lower().startswith("file") and el.get(a) not in state.assets]
        dirs = "meshdir" in el.attrib or "assetdir" in el.attrib or "texturedir" in el.attrib
        if leftover or dirs or (kind == "mjcf" and el.tag.lower() == "include"):
            raise ValueError(f"robot description {main}: <{el.tag}> names a file skillbank could not confine")
    return Described(kind, ET.tostring(root, encoding="unicode"), dict(state.assets), tuple(state.files))
