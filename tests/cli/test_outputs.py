"""Outputs are regular files, written whole, and a FIFO or a device is never replaced (issue 23, item 6)."""

from __future__ import annotations

import os
import stat

import pytest

from skillbank.io import atomic_output, check_output_path

REUSE = ["library", "reuse", "{lib}", "--skill", "press", "--method", "ja",
         "--goal", "-0.3073,-0.4437,0.1343", "--robot", "ur5e"]


@pytest.fixture(scope="module")
def press_library(tmp_path_factory, data_dir):
    from skillbank.cli._main import main

    folder = tmp_path_factory.mktemp("lib")
    lib = folder / "lib.db"
    assert main(["library", "init", str(lib)]) == 0
    assert main(["library", "add", str(lib), str(data_dir / "seed" / "three_button_pressing_demo.h5")]) == 0
    for primitive in ("2", "3", "4"):
        assert main(["library", "label", str(lib), "--primitive", primitive, "press"]) == 0
    return lib


def _listing(folder):
    return sorted((p.name, stat.S_IFMT(p.lstat().st_mode)) for p in folder.iterdir())


@pytest.mark.parametrize("args", [
    [*REUSE, "--out", "{fifo}.script"],
    [*REUSE, "--out", "{fifo}.csv"],
    [*REUSE, "--out", "{fifo}.npz"],
    [*REUSE, "--out", "good.csv", "--plot", "{fifo}.png"],
    ["segment", "{demo}", "--plot", "{fifo}.png"],
    ["segment", "{demo}", "--out", "{fifo}"],
    ["edit", "{demo}", "--goal", "0.1,0.1,0.1", "--out", "{fifo}.csv"],
    ["edit", "{demo}", "--goal", "0.1,0.1,0.1", "--out", "good.csv", "--plot", "{fifo}.png"],
], ids=lambda a: " ".join(a[:1] + a[-2:]))
def test_an_output_onto_a_fifo_is_refused_before_the_work(args, tmp_path, press_library, data_dir, cli,
                                                          monkeypatch):
    monkeypatch.chdir(tmp_path)
    target = [a for a in args if "{fifo}" in a][0].format(fifo="pipe")
    os.mkfifo(target)
    before = _listing(tmp_path)
    demo = data_dir / "seed" / "three_button_pressing_demo.h5"
    filled = [a.format(lib=press_library, demo=demo, fifo="pipe") for a in args]
    code, out, err = cli(*filled)
    assert code == 2 and out == ""
    assert err.count("\n") == 1
    option = "plot" if filled[filled.index(target) - 1] == "--plot" else "out"
    assert f"error: {option}: expected a regular file or a folder to write (or a new one), got '{target}', " \
           "a FIFO (named pipe)" in err
    assert _listing(tmp_path) == before  # the FIFO is still a FIFO and nothing else was written


def test_a_device_is_refused_and_left_alone():
    with pytest.raises(ValueError, match=r"^out: expected a regular file or a folder to write .*'/dev/null', "
                                         r"a character device"):
        check_output_path("/dev/null")
    with pytest.raises(ValueError, match=r"^plot: expected a regular file to write .*a character device"):
        with atomic_output("/dev/null", name="plot"):
            pass
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)


def test_a_failed_write_leaves_the_old_file(tmp_path):
    path = tmp_path / "x.csv"
    path.write_text("old")
    with pytest.raises(RuntimeError), atomic_output(path) as tmp:
        tmp.write_text("half")
        raise RuntimeError("the writer failed")
    assert path.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["x.csv"]
