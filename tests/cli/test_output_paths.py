"""One path for two outputs is refused; a link at an output is replaced, never written through (41)."""

from __future__ import annotations

import os

import pytest

from skillbank.io import atomic_output


def _listing(folder):
    return sorted((str(p.relative_to(folder)), p.is_symlink()) for p in folder.rglob("*"))


@pytest.mark.parametrize("argv, option, other", [
    (["sim", "run", "t.npz", "--scene", "s.json", "--plot", "same.gif", "--video", "same.gif"],
     "video", "plot"),
    (["sim", "run", "t.npz", "--scene", "s.json", "--plot", "sub/../same.png", "--video", "./same.png"],
     "video", "plot"),
    (["edit", "d.csv", "--goal", "0,0", "--out", "x.csv", "--plot", "x.csv"], "plot", "out"),
    (["segment", "d.csv", "--plot", "fig", "--out", "fig.png"], "plot", "out"),  # --plot fig writes fig.png
    (["plan", "lib.db", "--scene", "s.json", "--out", "p", "--view", "p"], "view", "out"),
    (["plan", "lib.db", "--scene", "s.json", "--out", "p.domain.pddl", "--plot", "p.png"], "plot", "out"),
    (["library", "reuse", "lib.db", "--skill", "press", "--out", "r.csv", "--plot", "linked/r.csv"],
     "plot", "out"),
], ids=lambda a: " ".join(a) if isinstance(a, list) else a)
def test_one_path_for_two_outputs_is_one_line_and_nothing_written(argv, option, other, cli, tmp_path,
                                                                  monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    os.symlink(".", tmp_path / "linked")  # a folder link: resolved before the paths are compared
    before = _listing(tmp_path)
    code, out, err = cli(*argv)
    assert code == 2 and out == ""
    assert err.count("\n") == 1, err
    assert f"error: {option}: " in err and f"which --{other} writes too" in err
    assert "give each output its own file" in err
    assert _listing(tmp_path) == before


def test_different_paths_pass_the_check(cli, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, _, err = cli("sim", "run", "missing.npz", "--scene", "s.json", "--plot", "a.png", "--video",
                       "a.gif")
    assert code == 2 and "is the path" not in err and "missing.npz" in err


@pytest.fixture
def outside(tmp_path):
    """A file outside the work folder, which a link in the work folder points to."""
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "work").mkdir()
    secret = tmp_path / "elsewhere" / "kept.txt"
    secret.write_text("not yours")
    return tmp_path / "work", secret


@pytest.mark.parametrize("dangling", [False, True])
def test_atomic_output_replaces_a_link_and_leaves_its_target(outside, dangling):
    work, secret = outside
    target = secret.with_name("new.csv") if dangling else secret
    link = work / "out.csv"
    os.symlink(target, link)
    with atomic_output(link, name="out") as tmp:
        tmp.write_text("written")
    assert not link.is_symlink() and link.read_text() == "written"
    assert secret.read_text() == "not yours" and not secret.with_name("new.csv").exists()
    assert sorted(p.name for p in work.iterdir()) == ["out.csv"]


def test_a_failed_write_leaves_the_link(outside):
    work, secret = outside
    link = work / "out.csv"
    os.symlink(secret, link)
    with pytest.raises(RuntimeError), atomic_output(link) as tmp:
        tmp.write_text("half")
        raise RuntimeError("the writer failed")
    assert link.is_symlink() and link.read_text() == "not yours"
    assert sorted(p.name for p in work.iterdir()) == ["out.csv"]


@pytest.mark.parametrize("option, name", [("--out", "edited.csv"), ("--plot", "edit.png")])
def test_out_and_plot_replace_a_link_on_the_command_line(option, name, outside, cli, data_dir):
    work, secret = outside
    before = secret.read_bytes()
    link = work / name
    os.symlink(secret, link)
    demo = data_dir / "seed" / "three_button_pressing_demo.h5"
    argv = ["edit", demo, "--goal", "0.1,0.1,0.1", option, link]
    if option == "--plot":
        argv += ["--out", work / "edited.csv"]
    else:  # a link there is an output there: replaced with --force only
        code, out, err = cli(*argv)
        assert code == 2 and err.startswith("skillbank edit: error: out: ") and "--force" in err, err
        assert link.is_symlink() and secret.read_bytes() == before
        argv.append("--force")
    code, out, err = cli(*argv)
    assert code == 0, err
    assert not link.is_symlink() and link.stat().st_size > 0
    assert secret.read_bytes() == before  # nothing written outside the folder


def test_the_plans_pddl_is_written_whole_and_replaces_a_link(outside):
    from skillbank.planning import PlanResult, write_pddl

    work, secret = outside
    os.symlink(secret, work / "plan.domain.pddl")
    result = PlanResult([], [], None, False, 0.0, {}, domain="(define (domain d))", problem="(define)")
    paths = write_pddl(result, work / "plan")
    assert [p.read_text() for p in paths] == ["(define (domain d))", "(define)"]
    assert not paths[0].is_symlink() and secret.read_text() == "not yours"
