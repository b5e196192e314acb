"""Issue 41, items 3 and 5: MuJoCo opens no file of a robot description, and the bounds come before the work.

Each way out of the folder a security probe found is a test: one clear error, and no file outside the
folder opened, checked for real in a child process under ``strace`` (every open and openat of the
child and its threads). Legitimate layouts load as MuJoCo itself loads them.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from skillbank.robots import check_description_files, load_description, robot_model
from skillbank.robots._description import _compile
from skillbank.robots._description_bounds import description_bound
from skillbank.robots._description_files import _nonfinite, read_description

mujoco = pytest.importorskip("mujoco")  # the extra skillbank[sim]

STRACE = shutil.which("strace")
ROOT = Path(__file__).resolve().parents[2]  # this checkout: the child imports its skillbank
ARM = ('<worldbody><body name="link"><joint name="j" axis="0 0 1"/><geom size="0.05"/></body>'
       '</worldbody>')


def stl(path: Path, scale: float = 1.0, extra: int = 0) -> Path:
    """A binary STL: a tetrahedron, with ``extra`` more triangles fanned round it (more vertices)."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float) * scale
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    tris = [v[list(f)] for f in faces]
    for k in range(extra):
        a = 2 * np.pi * k / max(extra, 1)
        tris.append(np.array([[0, 0, -scale], [np.cos(a), np.sin(a), -scale], [0, 0, -2 * scale]]))
    body = b"".join(struct.pack("<12fH", 0, 0, 0, *np.asarray(t, np.float32).ravel(), 0) for t in tris)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"\0" * 80 + struct.pack("<I", len(tris)) + body)
    return path


def png(path: Path, width: int = 4, height: int = 4, *, grey: bool = False) -> Path:
    """A small PNG (RGB, or 8-bit grey for a height field)."""
    channels = 1 if grey else 3
    rows = b"".join(b"\0" + bytes((x * 40 + y * 7) % 256 for x in range(width * channels))
                    for y in range(height))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    header = struct.pack(">IIBBBBB", width, height, 8, 0 if grey else 2, 0, 0, 0)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(rows))
                     + chunk(b"IEND", b""))
    return path


def urdf(links: int = 1, extra: str = "", mujoco_block: str = "", limit='lower="-1" upper="1"') -> str:
    lines = ['<robot name="r">', mujoco_block, '<link name="l0"/>']
    for i in range(links):
        lines.append(f'<link name="l{i + 1}"><collision><geometry><box size="0.1 0.1 0.1"/></geometry>'
                     '</collision></link>')
        lines.append(f'<joint name="j{i}" type="revolute"><parent link="l{i}"/><child link="l{i + 1}"/>'
                     f'<origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit {limit} effort="1" velocity="1"/>'
                     '</joint>')
    return "\n".join(lines + [extra, "</robot>"])


# ------------------------------------------------------------------------------- the ways out, under strace
# Each case: a folder "robot" with the description, beside "outside" with what it tries to reach. Returns
# the description and the error expected. The outside files are real (an unconfined read would succeed).


def _doctype(robot, outside):
    # Python's parser sees an entity, then a comment, then the harmless document; MuJoCo's (tinyxml2) ends
    # the DOCTYPE at the first '>' and takes the hidden <mujoco>, which includes the outside file
    hidden = f"<mujoco><include file='{outside}/secret.xml'/></mujoco>"
    (robot / "arm.xml").write_text(f'<!DOCTYPE r [<!ENTITY x "-> {hidden} <!--">]>\n<!-- --> '
                                   f'<mujoco>{ARM}</mujoco>')
    return robot / "arm.xml", r"arm.xml: declares a DOCTYPE or ENTITY, which MuJoCo's XML parser reads"


def _nested_include(robot, outside):
    # MuJoCo tries an include inside an include from the main file's folder first: ../outside; the
    # include's own folder (where robot/outside/ holds a harmless decoy) only when that is missing
    (robot / "outside").mkdir()
    (robot / "outside" / "secret.xml").write_text("<mujoco/>")
    (robot / "sub").mkdir()
    (robot / "sub" / "parts.xml").write_text('<mujoco><include file="../outside/secret.xml"/></mujoco>')
    (robot / "arm.xml").write_text(f'<mujoco><include file="sub/parts.xml"/>{ARM}</mujoco>')
    return robot / "arm.xml", r"parts.xml: <include> file '../outside/secret.xml' lies outside the"


def _mesh_in_include(robot, outside):
    # MuJoCo reads a mesh named in an include from the main file's folder (and meshdir) first
    stl(robot / "outside" / "secret.stl")  # the decoy, beside the include
    (robot / "sub").mkdir()
    (robot / "sub" / "parts.xml").write_text('<mujoco><asset><mesh name="m" file="../outside/secret.stl"/>'
                                             '</asset></mujoco>')
    (robot / "arm.xml").write_text(f'<mujoco><include file="sub/parts.xml"/>{ARM}</mujoco>')
    return robot / "arm.xml", r"parts.xml: <mesh> file '../outside/secret.stl' lies outside the description"


def _urdf_assetdir(robot, outside):
    mesh = '<link name="m"><collision><geometry><mesh filename="secret.stl"/></geometry></collision></link>'
    (robot / "r.urdf").write_text(urdf(extra=mesh, mujoco_block=f'<mujoco><compiler assetdir="{outside}"/>'
                                                                '</mujoco>'))
    return robot / "r.urdf", r"r.urdf: assetdir '.*outside' lies outside the description's folder"


def _later_assetdir(robot, outside):
    # MuJoCo applies each <compiler> in turn: the later assetdir "." replaces meshdir "a/b", under which
    # ../outside/secret.stl would have stayed inside (robot/a/outside/secret.stl)
    (robot / "arm.xml").write_text('<mujoco><compiler meshdir="a/b"/><compiler assetdir="."/><asset>'
                                   f'<mesh name="m" file="../outside/secret.stl"/></asset>{ARM}</mujoco>')
    return robot / "arm.xml", r"arm.xml: <mesh> file '../outside/secret.stl' lies outside the description's"


def _cube(robot, outside, right):
    png(robot / "sky.png")
    faces = 'fileup="sky.png" filedown="sky.png" filefront="sky.png" fileback="sky.png"'
    (robot / "arm.xml").write_text(f'<mujoco><asset><texture name="sky" type="skybox" {faces} '
                                   f'fileright="{right}" fileleft="sky.png"/></asset>{ARM}</mujoco>')
    return robot / "arm.xml", r"arm.xml: <texture> fileright '.*' lies outside the description's folder"


def _cube_outside_file(robot, outside):
    return _cube(robot, outside, f"{outside}/secret.png")


def _cube_missing_outside_file(robot, outside):
    return _cube(robot, outside, f"{outside}/missing.png")


def _cube_device(robot, outside):
    return _cube(robot, outside, "/dev/zero")


def _hfield(robot, outside):
    # MuJoCo 3.3.7 reads a height field under meshdir, not assetdir
    (robot / "arm.xml").write_text('<mujoco><compiler assetdir="a" meshdir="."/><asset><hfield name="h" '
                                   f'file="../outside/h.png" size="1 1 1 0.1"/></asset>{ARM}</mujoco>')
    return robot / "arm.xml", r"arm.xml: <hfield> file '../outside/h.png' lies outside the description"


def _fifo_include(robot, outside):
    os.mkfifo(robot / "parts.xml")  # opened, it would block: refused unopened
    (robot / "arm.xml").write_text(f'<mujoco><include file="parts.xml"/>{ARM}</mujoco>')
    return robot / "arm.xml", r"arm.xml: <include> file 'parts.xml' is a FIFO, not a regular file"


def _fifo_mesh(robot, outside):
    (robot / "meshes").mkdir()
    os.mkfifo(robot / "meshes" / "m.stl")
    (robot / "arm.xml").write_text('<mujoco><compiler meshdir="meshes"/><asset><mesh name="m" file="m.stl"/>'
                                   f'</asset>{ARM}</mujoco>')
    return robot / "arm.xml", r"arm.xml: <mesh> file 'm.stl' is a FIFO, not a regular file"


def _include_bomb(robot, outside):
    # 8 files, each including the next 8 times under 8 spellings: 8^8 parses for MuJoCo, 2 files here
    for k in range(8):
        spellings = [f"{'./' * s}f{k + 1}.xml" for s in range(8)] if k < 7 else []
        includes = "".join(f'<include file="{s}"/>' for s in spellings)
        (robot / f"f{k}.xml").write_text(f"<mujocoinclude>{includes}<default/></mujocoinclude>")
    (robot / "arm.xml").write_text(f'<mujoco><include file="f0.xml"/>{ARM}</mujoco>')
    return robot / "arm.xml", r"f\d.xml: <include> file '\./f\d.xml' is included twice \(MuJoCo includes a " \
                              r"file once\)"


def _thousand_links(robot, outside):
    (robot / "r.urdf").write_text(urdf(1000))
    return robot / "r.urdf", r"r.urdf: 101 or more bodies \(links\), more than the bound of 100; set " \
                             r"SKILLBANK_MAX_DESCRIPTION_BODIES to a larger number to read it$"


def _boxes(robot, outside):
    boxes = "".join(f'<geom type="box" size="0.1 0.1 0.1" pos="{i * 1e-3:.3f} 0 0"/>' for i in range(100_000))
    (robot / "arm.xml").write_text(f'<mujoco><worldbody><body name="b"><joint name="j"/>{boxes}</body>'
                                   '</worldbody></mujoco>')
    return robot / "arm.xml", r"arm.xml: 1001 or more geoms \(visual and collision\), more than the " \
                              r"bound of 1000; set SKILLBANK_MAX_DESCRIPTION_GEOMS"


def _huge_mesh(robot, outside):
    with open(robot / "big.stl", "wb") as f:  # sparse: 1 GiB that takes no disk
        f.truncate(1 << 30)
    (robot / "arm.xml").write_text(f'<mujoco><asset><mesh name="m" file="big.stl"/></asset>{ARM}</mujoco>')
    return robot / "arm.xml", r"<mesh> file 'big.stl' has 1073741824 bytes, more than the bound of " \
                              r"67108864 bytes in one file; set SKILLBANK_MAX_DESCRIPTION_FILE_BYTES"


def _huge_main(robot, outside):
    with open(robot / "arm.xml", "wb") as f:
        f.write(b"<mujoco>")
        f.truncate(1 << 30)
    return robot / "arm.xml", r"arm.xml: the file has 1073741824 bytes, more than the bound"


WAYS_OUT = {f.__name__[1:]: f for f in (_doctype, _nested_include, _mesh_in_include, _urdf_assetdir,
                                        _later_assetdir, _cube_outside_file, _cube_missing_outside_file,
                                        _cube_device, _hfield, _fifo_include, _fifo_mesh, _include_bomb,
                                        _thousand_links, _boxes, _huge_mesh, _huge_main)}

PROBE = """
import json, sys, time
from skillbank.robots import robot_model
out = {}
for name, path in json.loads(sys.argv[1]).items():
    start = time.perf_counter()
    try:
        robot_model(path)
        out[name] = [None, time.perf_counter() - start]
    except ValueError as e:
        out[name] = [str(e), time.perf_counter() - start]
print(json.dumps(out))
"""


@pytest.fixture(scope="module")
def probed(tmp_path_factory):
    """Every way out loaded in one child process: ``{case: (error, seconds, files opened outside)}``."""
    base = tmp_path_factory.mktemp("ways_out")
    cases, expected = {}, {}
    for name, build in WAYS_OUT.items():
        robot, outside = base / name / "robot", base / name / "outside"
        robot.mkdir(parents=True)
        outside.mkdir()
        (outside / "secret.xml").write_text(f"<mujocoinclude>{ARM.replace('link', 'stolen')}</mujocoinclude>")
        stl(outside / "secret.stl")
        png(outside / "secret.png")
        png(outside / "h.png", grey=True)
        if STRACE is None:  # no strace: an outside file opened would block the child, and time it out
            for f in outside.iterdir():
                f.unlink()
                os.mkfifo(f)
        path, expected[name] = build(robot, outside)
        cases[name] = str(path)
    trace = base / "trace.txt"
    prefix = [STRACE, "-f", "-qq", "-e", "trace=open,openat,openat2", "-o", str(trace)] if STRACE else []
    env = {**os.environ,
           "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    done = subprocess.run([*prefix, sys.executable, "-c", PROBE, json.dumps(cases)], cwd=base, env=env,
                          capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL)
    assert done.returncode == 0, done.stderr[-3000:]
    results = json.loads(done.stdout.strip().splitlines()[-1])
    calls = trace.read_text() if STRACE else ""
    written = re.findall(r'open(?:at2?)?\((?:AT_FDCWD, |\d+, )?"([^"]*)"', calls)
    opened = [os.path.normpath(os.path.join(base, p)) for p in written]  # robot/../outside is outside
    return {name: (results[name][0], results[name][1], expected[name],
                   [p for p in opened if p.startswith(str(base / name / "outside")) or p == "/dev/zero"],
                   [p for p in opened if p.startswith(str(base / name / "robot"))])
            for name in cases}


@pytest.mark.parametrize("case", sorted(WAYS_OUT))
def test_each_way_out_is_one_clear_error_and_nothing_outside_is_opened(probed, case):
    error, seconds, expected, outside, _ = probed[case]
    assert error is not None and re.search(expected, error), error
    assert "\n" not in error and error.startswith("robot description ")
    assert outside == []  # strace: not one open() of a file outside the folder, nor of /dev/zero
    assert seconds < 30  # refused before the work (MuJoCo took over 60 s on the bomb and the 1000 links)


def test_refused_files_are_never_opened_and_an_error_does_not_tell_whether_an_outside_file_exists(probed):
    if STRACE is None:
        pytest.skip("strace not installed: the FIFOs outside proved nothing was opened there")
    for case, name in [("fifo_include", "parts.xml"), ("fifo_mesh", "m.stl"), ("huge_mesh", "big.stl")]:
        assert not [p for p in probed[case][4] if p.endswith(name)], case  # checked, refused, not opened
    there, missing = probed["cube_outside_file"][0], probed["cube_missing_outside_file"][0]
    assert there.replace("secret.png", "X").replace("cube_outside_file", "C") == \
        missing.replace("missing.png", "X").replace("cube_missing_outside_file", "C")


# --------------------------------------------------------------------------- what MuJoCo itself would load


def _agree(path: Path) -> None:
    """The model compiled from memory is the one MuJoCo compiles reading the same files itself."""
    ours = _compile(path, read_description(path))
    spec = mujoco.MjSpec.from_file(str(path))
    spec.compiler.fusestatic, spec.compiler.boundmass, spec.compiler.boundinertia = False, 1e-6, 1e-9
    theirs = spec.compile()
    for field in ("nbody", "njnt", "ngeom", "nmesh", "ntex", "nhfield"):
        assert getattr(ours, field) == getattr(theirs, field), field
    for field in ("mesh_vertnum", "tex_width", "tex_height", "hfield_nrow", "hfield_ncol", "body_pos",
                  "jnt_range", "geom_size"):
        np.testing.assert_allclose(getattr(ours, field), getattr(theirs, field), err_msg=field)
    for i in range(theirs.nmesh):
        assert ours.mesh(i).name == theirs.mesh(i).name
        np.testing.assert_allclose(ours.mesh_vert[ours.mesh_vertadr[i]:][:ours.mesh_vertnum[i]],
                                   theirs.mesh_vert[theirs.mesh_vertadr[i]:][:theirs.mesh_vertnum[i]])


def test_mjcf_folders_includes_and_textures_resolve_as_mujocos_own(tmp_path):
    stl(tmp_path / "a" / "m.stl", extra=1)  # the first compiler's meshdir: the later assetdir wins
    stl(tmp_path / "b" / "m.stl", extra=5)
    stl(tmp_path / "sub" / "near.stl", extra=3)  # only beside the include: MuJoCo's second try
    for face in ("r", "l", "u", "d", "f", "k"):
        png(tmp_path / "tex" / f"{face}.png", 8, 8)
    png(tmp_path / "tex" / "wood.png", 16, 8)
    png(tmp_path / "b" / "ground.png", 5, 7, grey=True)
    (tmp_path / "sub" / "parts.xml").write_text(
        '<mujocoinclude><asset><mesh file="near.stl"/><mesh name="shell" file="m.stl"/></asset>'
        '</mujocoinclude>')
    (tmp_path / "arm.xml").write_text(
        '<mujoco model="arm"><compiler meshdir="a"/><compiler assetdir="b" texturedir="tex"/>'
        '<include file="sub/parts.xml"/><asset><hfield name="ground" file="ground.png" size="1 1 0.1 0.1"/>'
        '<texture name="sky" type="skybox" fileright="r.png" fileleft="l.png" fileup="u.png" '
        'filedown="d.png" filefront="f.png" fileback="k.png"/><texture name="wood" type="2d" '
        'file="wood.png"/></asset>'
        '<worldbody><geom type="hfield" hfield="ground"/><body name="link"><joint name="j" axis="0 0 1"/>'
        '<geom type="mesh" mesh="near"/><geom type="mesh" mesh="shell"/></body></worldbody></mujoco>')
    _agree(tmp_path / "arm.xml")
    described = read_description(tmp_path / "arm.xml")
    assert "/" not in described.xml.replace("</", "").replace("/>", "")  # no path reaches MuJoCo
    assert len(described.files) == 12  # main, include, 2 meshes (not a/m.stl), 6 faces, wood, ground
    assert check_description_files(tmp_path / "arm.xml") == "mjcf"


def test_urdf_meshes_resolve_as_mujocos_own_and_discarded_visuals_are_not_read(tmp_path):
    stl(tmp_path / "meshes" / "base.stl", extra=2)
    stl(tmp_path / "meshes" / "arm.stl", extra=4)
    os.mkfifo(tmp_path / "meshes" / "visual.stl")  # a visual MuJoCo discards: never opened
    links = ('<link name="base"><collision><geometry><mesh filename="package://robot/meshes/base.stl"/>'
             '</geometry></collision><visual><geometry><mesh filename="visual.stl"/></geometry></visual>'
             '</link>'
             '<link name="arm"><collision><geometry><mesh filename="file://meshes/arm.stl" scale="2 2 2"/>'
             '</geometry></collision></link>'
             '<joint name="j" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>'
             '<limit lower="-2" upper="2" effort="1" velocity="1"/></joint>')
    (tmp_path / "r.urdf").write_text(f'<robot name="r"><mujoco><compiler meshdir="meshes"/></mujoco>{links}'
                                     '</robot>')
    _agree(tmp_path / "r.urdf")
    assert robot_model(tmp_path / "r.urdf").limits.tolist() == [[-2.0, 2.0]]


def test_the_registered_panda_is_read_from_memory(tmp_path):
    path = robot_model("panda").chain.source
    described = read_description(path)
    assert described.kind == "mjcf" and len(described.assets) == 58 and len(described.files) == 59
    _agree(Path(path))


# ------------------------------------------------------------------------------ numbers and URDF limits


@pytest.mark.parametrize("limit, match", [
    ('lower="1" upper="-1"', r"joint 'j0' has its lower limit 1 above its upper limit -1; give lower <= "
                             r"upper"),
    ('lower="nan" upper="1"', r"<limit> lower='nan' holds 'nan', not a finite number; give finite numbers"),
    ('lower="-1" upper="1e999"', r"<limit> upper='1e999' holds '1e999', not a finite number"),
    ('lower="-INF" upper="1"', r"<limit> lower='-INF' holds '-INF', not a finite number"),
    ('lower="-1"', r"joint 'j0' has a <limit> with only lower; give both lower and upper"),
])
def test_urdf_limits_that_mujoco_would_drop_are_refused(tmp_path, limit, match):
    path = tmp_path / "r.urdf"
    path.write_text(urdf(2, limit=limit))
    with pytest.raises(ValueError, match=match):
        load_description(path)


def test_a_nan_is_refused_before_mujoco_prints_on_stdout(tmp_path, capfd):
    path = tmp_path / "arm.xml"
    path.write_text('<mujoco><worldbody><body name="b" pos="0 NaN 0"><joint name="j"/><geom size="0.1"/>'
                    '</body></worldbody></mujoco>')
    with pytest.raises(ValueError, match=r"arm.xml: <body> pos='0 NaN 0' holds 'NaN', not a finite number"):
        load_description(path)
    assert capfd.readouterr().out == ""


def test_what_mujoco_prints_while_it_compiles_goes_to_stderr(tmp_path, capfd, monkeypatch):
    from skillbank.robots._description_files import Described

    monkeypatch.chdir(tmp_path)  # MuJoCo also logs its warnings to MUJOCO_LOG.TXT in the working folder

    nan = Described("mjcf", '<mujoco><worldbody><body pos="0 nan 0"><joint/><geom size="1"/></body>'
                            '</worldbody></mujoco>', {}, ())  # past the checks: MuJoCo warns, then fails
    with pytest.raises(ValueError, match=r"arm.xml: MuJoCo cannot read this MJCF \(Nan, Inf or huge value"):
        _compile(tmp_path / "arm.xml", nan)
    out, err = capfd.readouterr()
    assert out == "" and "WARNING: XML contains a 'NaN'" in err


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_finite_numbers_pass_and_their_non_finite_spellings_do_not(x):
    for text in (repr(x), f"{x:.17e}", f"{x:g}", x.hex()):
        assert not _nonfinite(text)
    for text in ("nan", "-NaN", "nan(0x1)", "inf", "+Infinity", "1e999", "-1E+400", "0x1p99999"):
        assert _nonfinite(text)


def test_the_cli_refuses_a_bad_description_with_one_line_and_an_empty_stdout(cli, tmp_path):
    bad = tmp_path / "r.urdf"
    bad.write_text(urdf(2, limit='lower="nan" upper="1"'))
    code, out, err = cli("edit", tmp_path / "demo.csv", "--robot", bad, "--json")
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert "holds 'nan', not a finite number; give finite numbers" in err
    (tmp_path / "outside.stl").write_bytes(b"x")
    (tmp_path / "robot").mkdir()
    escape = tmp_path / "robot" / "arm.xml"
    escape.write_text(f'<mujoco><asset><mesh name="m" file="../outside.stl"/></asset>{ARM}</mujoco>')
    code, out, err = cli("edit", tmp_path / "demo.csv", "--robot", escape, "--json")
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert "<mesh> file '../outside.stl' lies outside the description's folder" in err


# ---------------------------------------------------------------------------------------------- bounds


def test_each_bound_has_a_variable_that_raises_it(tmp_path, monkeypatch):
    path = tmp_path / "r.urdf"
    path.write_text(urdf(3))
    monkeypatch.setenv("SKILLBANK_MAX_DESCRIPTION_JOINTS", "2")
    with pytest.raises(ValueError, match=r"r.urdf: 3 or more joints, more than the bound of 2; set "
                                         r"SKILLBANK_MAX_DESCRIPTION_JOINTS to a larger number to read it$"):
        load_description(path)
    monkeypatch.setenv("SKILLBANK_MAX_DESCRIPTION_JOINTS", "3")
    assert load_description(path).joint_names == ("j0", "j1", "j2")
    monkeypatch.setenv("SKILLBANK_MAX_DESCRIPTION_GEOMS", "2")
    with pytest.raises(ValueError, match=r"3 or more geoms \(visual and collision\), more than the bound"):
        read_description(path)
    monkeypatch.setenv("SKILLBANK_MAX_DESCRIPTION_BYTES", "100")
    with pytest.raises(ValueError, match=r"its files hold more than the bound of 100 bytes in all .* set "
                                         r"SKILLBANK_MAX_DESCRIPTION_BYTES"):
        read_description(path)
    monkeypatch.setenv("SKILLBANK_MAX_DESCRIPTION_BYTES", "lots")
    with pytest.raises(ValueError, match=r"^SKILLBANK_MAX_DESCRIPTION_BYTES: expected a whole number >= 1 "
                                         r"\(e.g. 1e4\), got 'lots'$"):
        read_description(path)
    assert description_bound("INCLUDES", {"SKILLBANK_MAX_DESCRIPTION_INCLUDES": "2e3"}) == 2000


def test_includes_and_pixels_are_bounded(tmp_path, monkeypatch):
    for k in range(3):
        (tmp_path / f"p{k}.xml").write_text("<mujocoinclude><default/></mujocoinclude>")
    (tmp_path / "arm.xml").write_text("<mujoco>" + "".join(f'<include file="p{k}.xml"/>' for k in range(3))
                                      + f"{ARM}</mujoco>")
    monkeypatch.setenv("SKILLBANK_MAX_DESCRIPTION_INCLUDES", "2")
    with pytest.raises(ValueError, match=r"3 included files, more than the bound of 2"):
        read_description(tmp_path / "arm.xml")
    monkeypatch.delenv("SKILLBANK_MAX_DESCRIPTION_INCLUDES")
    assert read_description(tmp_path / "arm.xml").kind == "mjcf"
    for k in range(3):  # each file within the bound, the description over it once expanded
        (tmp_path / f"p{k}.xml").write_text(f'<mujocoinclude><body name="b{k}"/></mujocoinclude>')
    includes = "".join(f'<include file="p{k}.xml"/>' for k in range(3))
    (tmp_path / "arm.xml").write_text(f"<mujoco><worldbody>{includes}</worldbody></mujoco>")
    monkeypatch.setenv("SKILLBANK_MAX_DESCRIPTION_BODIES", "2")
    with pytest.raises(ValueError, match=r"arm.xml: 3 bodies \(links\), more than the bound of 2"):
        read_description(tmp_path / "arm.xml")
    monkeypatch.delenv("SKILLBANK_MAX_DESCRIPTION_BODIES")
    png(tmp_path / "wide.png", 4, 4)
    data = bytearray((tmp_path / "wide.png").read_bytes())
    data[16:24] = struct.pack(">II", 100_000, 100_000)  # the header of a decompression bomb
    (tmp_path / "wide.png").write_bytes(bytes(data))
    (tmp_path / "arm.xml").write_text(f'<mujoco><asset><texture name="t" type="2d" file="wide.png"/></asset>'
                                      f'{ARM}</mujoco>')
    with pytest.raises(ValueError, match=r"10000000000 pixels in <texture> file 'wide.png' \(100000 x "
                                         r"100000\), more than the bound of 33554432; set "
                                         r"SKILLBANK_MAX_DESCRIPTION_PIXELS"):
        read_description(tmp_path / "arm.xml")
    for asset in ('<texture name="t" type="2d" builtin="checker" width="40000" height="40000"/>',
                  '<hfield name="h" nrow="4e4" ncol="40000.5" size="1 1 1 1"/>'):
        (tmp_path / "arm.xml").write_text(f"<mujoco><asset>{asset}</asset>{ARM}</mujoco>")
        with pytest.raises(ValueError, match=r"1600000000 pixels in <(texture width|hfield nrow)=40000 "):
            read_description(tmp_path / "arm.xml")


def test_nesting_is_bounded_in_a_file_and_across_includes(tmp_path):
    (tmp_path / "arm.xml").write_text("<mujoco>" + "<default>" * 500 + "</default>" * 500 + "</mujoco>")
    with pytest.raises(ValueError, match=r"arm.xml: elements nested more than 490 deep \(MuJoCo's XML"):
        read_description(tmp_path / "arm.xml")
    for k in range(3):  # 300 deep each: 900 once expanded
        inner = f'<include file="p{k + 1}.xml"/>' if k < 2 else ""
        (tmp_path / f"p{k}.xml").write_text("<x>" + "<default>" * 300 + inner + "</default>" * 300 + "</x>")
    (tmp_path / "arm.xml").write_text('<mujoco><include file="p0.xml"/></mujoco>')
    with pytest.raises(ValueError, match=r"arm.xml: elements nested more than 490 deep"):
        read_description(tmp_path / "arm.xml")


@pytest.mark.parametrize("body, match", [
    ('<asset><model name="m" file="other.xml"/></asset>', r"<model> is not supported"),
    ('<worldbody><replicate count="1000000"><geom size="1"/></replicate></worldbody>',
     r"<replicate> is not supported \(skillbank reads an arm's bodies, joints and geoms\)"),
    ('<INCLUDE file="x.xml"/>', r"<include> file 'x.xml' is no file in the description's folder"),
    ('<worldbody><geom file="x.stl"/></worldbody>', r"<geom> file names a file MuJoCo would read that"),
])
def test_what_skillbank_does_not_read_is_refused(tmp_path, body, match):
    (tmp_path / "arm.xml").write_text(f"<mujoco>{body}{ARM}</mujoco>")
    with pytest.raises(ValueError, match=match):
        read_description(tmp_path / "arm.xml")
