"""``skillbank library``: the end-to-end loop on real RAIL data, output shapes and error exits."""

from __future__ import annotations

import json
import os
import re
import sqlite3
from pathlib import Path

import numpy as np
import pytest


@pytest.fixture
def run(cli):
    return cli


def shown(db) -> str:
    """How the CLI names the library at ``db``: a URL's password masked."""
    return re.sub(r"^(postgresql://[^:/@]+:)[^@]*@", r"\1***@", str(db))


def test_end_to_end_on_rail(run, tmp_path, new_library, data_dir):
    db, rail = new_library("skills"), data_dir / "rail"
    assert run("library", "init", db)[0] == 0
    code, out, err = run("library", "add", db, rail / "REACHING" / "1.mat", rail / "REACHING" / "2.mat",
                         "--whole", "--label", "reaching", "--json")
    assert code == 0, err
    added = json.loads(out)
    assert len(added["demonstrations"]) == 12 and all(len(p) == 1 for p in added["primitives"])
    code, out, err = run("library", "add", db, rail / "PRESSING" / "1.mat", "--window", "32",
                         "--threshold", "0.3", "--assign", "none")
    assert code == 0, err and "added 6 demonstration(s)" in out
    code, out, err = run("library", "cluster", db, "--stretch", "1.2", "--json")
    assert code == 0, err
    clustered = json.loads(out)
    assert clustered["version"] == 1 and sum(s["count"] for s in clustered["skills"]) > 12
    assert run("library", "label", db, "--cluster", "0", "first")[0] == 0
    code, out, _ = run("library", "list", db, "--json")
    doc = json.loads(out)
    assert set(doc) == {"n_demonstrations", "version", "skills", "primitives", "unassigned", "demonstrations"}
    assert doc["n_demonstrations"] == 18
    # RAIL's end-effector positions name no point of the robot: unknown, shown as such, never guessed
    assert {d["pose_of"] for d in doc["demonstrations"]} == {None}
    assert doc["skills"][0] == {"cluster": 0, "label": "first", "count": doc["skills"][0]["count"],
                                "label_source": "given"}
    assert set(doc["primitives"][0]) == {"id", "demonstration", "cluster", "label", "label_source", "n_steps",
                                         "acts_on", "pose_of", "arm_index"}
    assert doc["primitives"][0]["acts_on"] is None  # RAIL records no object poses
    assert [p["label"] for p in doc["primitives"][:12]] == ["reaching"] * 12
    assert doc["primitives"][0]["n_steps"] == 1000
    code, text, _ = run("library", "list", db)
    assert code == 0 and "cluster 0:" in text and "label first" in text
    from skillbank.io import read_rail_file

    held = read_rail_file(rail / "REACHING" / "3.mat")[0]["position"]
    start, goal = ",".join(f"{v:.4f}" for v in held[0]), ",".join(f"{v:.4f}" for v in held[-1])
    code, out, err = run("library", "reuse", db, "--skill", "reaching", "--start", start, "--goal", goal,
                         "--method", "promp", "--seed", "0", "--json", "--plot", tmp_path / "reuse.png",
                         "--out", tmp_path / "reuse.npz")
    assert code == 0, err
    res = json.loads(out)
    assert set(res) >= {"trajectory", "used", "rejected", "constraint_error", "collision"}
    Y = np.asarray(res["trajectory"])
    assert Y.shape[1] == 3
    assert np.allclose(Y[0], held[0], atol=1e-3) and np.allclose(Y[-1], held[-1], atol=1e-3)
    assert set(res["used"]) <= set(range(1, 13)) and res["collision"] is False
    assert (tmp_path / "reuse.png").stat().st_size > 0 and (tmp_path / "reuse.npz").exists()


def test_export_import_remove_and_text_output(run, tmp_path, new_library):
    from skillbank import Demonstration
    from skillbank.io import write_npz

    t = np.linspace(0.0, 1.0, 40)
    for k in range(3):
        write_npz(Demonstration.from_array(np.column_stack([t, k * t]), t), tmp_path / f"d{k}.npz")
    db, copy = new_library("a"), new_library("b")
    files = [tmp_path / f"d{k}.npz" for k in range(3)]
    code, out, err = run("library", "add", db, *files, "--whole")
    assert code == 2 and "does not exist" in err  # no implicit creation outside init
    run("library", "init", db)
    code, out, err = run("library", "add", db, *files, "--whole")
    assert code == 0 and "added 3 demonstration(s) with 3 primitive(s)" in out
    assert run("library", "label", db, "--primitive", "2", "slope")[0] == 0
    code, out, _ = run("library", "export", db, tmp_path / "exp")
    assert code == 0 and (tmp_path / "exp" / "manifest.json").exists()
    code, out, _ = run("library", "import", copy, tmp_path / "exp", "--json")
    assert code == 0 and json.loads(out)["demonstrations"] == {"1": 1, "2": 2, "3": 3}
    assert json.loads(run("library", "list", copy, "--json")[1]) == \
        json.loads(run("library", "list", db, "--json")[1])
    assert run("library", "remove", db, "1")[0] == 0
    assert json.loads(run("library", "list", db, "--json")[1])["n_demonstrations"] == 2


def test_errors_exit_2_with_one_line(run, tmp_path):
    junk = tmp_path / "junk.db"
    junk.write_text("not a database\n")
    future = tmp_path / "future.db"
    run("library", "init", future)
    conn = sqlite3.connect(future)
    conn.execute("PRAGMA user_version = 7")
    conn.close()
    for argv, match in [
        (("library", "list", junk), "not a SQLite file"),
        (("library", "init", junk), "not a SQLite file"),
        (("library", "list", future), "newer skillbank"),
        (("library", "reuse", future, "--skill", "x", "--start", "0,0"), "newer skillbank"),
    ]:
        code, out, err = run(*argv)
        assert code == 2 and match in err and err.count("\n") == 1, (argv, err)
        assert err.startswith(f"skillbank library {argv[1]}: error:")


def test_usage_errors_exit_2_with_one_line(run, new_library):
    db = new_library("ok")
    code, out, err = run("library", "list", db)  # a missing file, or a database without a library
    assert code == 2 and "does not exist" in err and err.count("\n") == 1, err
    assert err.startswith("skillbank library list: error:")
    run("library", "init", db)
    code, _, err = run("library", "label", db, "--cluster", "0", "x")
    assert code == 2 and "no clusters yet" in err
    code, _, err = run("library", "reuse", db, "--skill", "x", "--start", "0,nope")
    assert code == 2 and "start: expected a number" in err
    code, _, err = run("library", "reuse", db, "--skill", "x", "--start", "0,0")
    assert code == 2 and "no primitive has label 'x'" in err


def test_reuse_accepts_negative_coordinates(run, tmp_path, new_library):
    from skillbank import Demonstration
    from skillbank.io import write_npz

    t = np.linspace(0.0, 1.0, 60)
    files = []
    for k in range(3):
        path = tmp_path / f"arc{k}.npz"
        write_npz(Demonstration.from_array(np.column_stack([t, np.sin(np.pi * t) * (1 + 0.1 * k)]), t), path)
        files.append(path)
    db = new_library("neg")
    run("library", "init", db)
    run("library", "add", db, *files, "--whole", "--label", "arc")
    code, out, err = run("library", "reuse", db, "--skill", "arc", "--start", "-0.5,-0.25",
                         "--goal", "1,0", "--method", "lte", "--json")
    assert code == 0, err
    result = json.loads(out)
    np.testing.assert_allclose(result["trajectory"][0], [-0.5, -0.25], atol=1e-9)
    np.testing.assert_allclose(result["trajectory"][-1], [1.0, 0.0], atol=1e-9)


def test_cli_and_library_share_one_list_of_methods(cli):
    """The CLI keeps no list of its own: an unknown method is refused with the registry's names."""
    from skillbank.representations import REPRESENTATIONS
    from skillbank.selection import METHODS

    assert METHODS == tuple(REPRESENTATIONS)
    code, _, err = cli("edit", "missing.csv", "--method", "nope")
    assert code == 2 and err.strip().endswith(f"method: expected one of {list(REPRESENTATIONS)}, got 'nope'")


def _wave_files(folder, specs):
    """CSV demonstrations ``name: (n_samples, n_dims, k)``: a 3-D (or 2-D) wave of frequency k."""
    from skillbank import Demonstration
    from skillbank.io import write_csv

    paths = []
    for name, (n, dims, k) in specs.items():
        t = np.linspace(0.0, 1.0, n)
        Y = np.column_stack([np.sin(3 * k * t), np.cos(2 * t), t][:dims])
        paths.append(write_csv(Demonstration.from_array(Y, t), folder / f"{name}.csv"))
    return paths


BATCH = {"good": (200, 3, 1.0), "g0": (200, 3, 1.5), "four_rows": (4, 3, 1.0), "g1": (200, 3, 2.0)}


def test_add_is_all_or_nothing_and_names_the_bad_file(run, tmp_path, new_library):
    db = new_library()
    files = _wave_files(tmp_path, BATCH)
    run("library", "init", db)
    for _ in range(2):  # again: still nothing added, nothing duplicated
        code, out, err = run("library", "add", db, *files)
        assert code == 2 and out == "" and err.count("\n") == 1, err
        assert err.startswith(f"skillbank library add: error: {files[2]}: ")
        assert "expected at least 16 samples" in err and "nothing was added" in err
        assert json.loads(run("library", "list", db, "--json")[1])["n_demonstrations"] == 0


def test_keep_going_adds_the_good_files_and_lists_the_bad_ones(run, tmp_path, new_library):
    db = new_library()
    files = _wave_files(tmp_path, BATCH)
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"\x00" * 64)
    run("library", "init", db)
    code, out, err = run("library", "add", db, *files, junk, "--keep-going")
    assert code == 2
    lines = err.splitlines()
    assert lines[0].startswith(f"skillbank library add: skipped {files[2]}: ")
    assert "expected at least 16 samples" in lines[0]
    assert lines[1].startswith(f"skillbank library add: skipped {junk}: ")
    assert lines[2] == "skillbank library add: error: 2 of 5 file(s) failed and were skipped; the other 3 " \
                       "were added"
    assert len(lines) == 3
    assert out.startswith(f"{shown(db)}: added 3 demonstration(s) with ")
    assert json.loads(run("library", "list", db, "--json")[1])["n_demonstrations"] == 3
    code, out, err = run("library", "add", db, files[0], files[2], "--keep-going", "--json")
    doc = json.loads(out)
    assert code == 2 and doc["demonstrations"] == [4] and list(doc["failed"]) == [str(files[2])]
    assert err.splitlines()[-1].startswith("skillbank library add: error: 1 of 2 file(s) failed")


def _clustered(run, folder, db=None):
    """A library of six 3-D waves, clustered (at ``db``, else a file in ``folder``), and a 2-D wave file."""
    db = folder / "c.db" if db is None else db
    specs = {f"w{k}": (200, 3, 1.0 + 0.5 * (k % 2)) for k in range(6)}
    run("library", "init", db)
    assert run("library", "add", db, *_wave_files(folder, specs), "--whole")[0] == 0
    assert run("library", "cluster", db)[0] == 0
    return db, _wave_files(folder, {"flat": (200, 2, 1.0)})[0]


def test_list_shows_unassigned_primitives_and_cluster_assigns_them(run, tmp_path, new_library):
    db, flat = _clustered(run, tmp_path, new_library())
    more = _wave_files(tmp_path, {"m0": (200, 3, 1.0), "m1": (200, 3, 1.5)})
    assert run("library", "add", db, *more, "--whole", "--assign", "none")[0] == 0
    doc = json.loads(run("library", "list", db, "--json")[1])
    assert doc["unassigned"] == {"count": 2, "ids": [7, 8]}
    text = run("library", "list", db)[1]
    assert "unassigned: 2 primitive(s) in no cluster of version 1: 7, 8 (run 'skillbank library cluster')" \
        in text
    code, out, _ = run("library", "cluster", db, "--json")
    assert code == 0 and json.loads(out)["version"] == 2
    doc = json.loads(run("library", "list", db, "--json")[1])
    assert doc["unassigned"] == {"count": 0, "ids": []} and sum(s["count"] for s in doc["skills"]) == 8
    assert not [line for line in run("library", "list", db)[1].splitlines() if line.startswith("unassigned")]


def test_a_demonstration_that_cannot_join_is_reported(run, tmp_path, new_library):
    db, flat = _clustered(run, tmp_path, new_library())
    code, out, err = run("library", "add", db, flat, "--whole")
    assert code == 0, err
    assert "demonstration 7: 1 primitive(s) left unclustered: its positions have 2 dimension(s), " \
           "clustering version 1 was fitted on 3-D positions" in out
    code, out, err = run("library", "add", db, flat, "--whole", "--json")
    assert json.loads(out)["unclustered"] == {"8": "its positions have 2 dimension(s), clustering version 1 "
                                                     "was fitted on 3-D positions"}
    assert json.loads(run("library", "list", db, "--json")[1])["unassigned"] == {"count": 2, "ids": [7, 8]}


def test_every_library_command_prints_json_and_cluster_ids_agree(run, tmp_path, new_library):
    db = new_library("j")
    code, out, _ = run("library", "init", db, "--json")
    assert code == 0 and json.loads(out) == {"library": shown(db), "created": True, "schema_version": 3}
    assert json.loads(run("library", "init", db, "--json")[1])["created"] is False
    specs = {f"w{k}": (200, 3, 1.0 + 2.0 * (k % 2)) for k in range(6)}
    run("library", "add", db, *_wave_files(tmp_path, specs), "--whole")
    code, out, _ = run("library", "cluster", db, "--json")
    skills = json.loads(out)["skills"]
    ids = [s["cluster"] for s in skills]
    assert ids == list(range(len(ids)))  # 0..k-1, as in 'list', 'label' and 'reuse --skill'
    assert [s["cluster"] for s in json.loads(run("library", "list", db, "--json")[1])["skills"]] == ids
    text = run("library", "cluster", db)[1]
    assert [int(line.split()[1][:-1]) for line in text.splitlines()[1:]] == ids
    code, out, _ = run("library", "label", db, "--cluster", str(ids[-1]), "last", "--json")
    assert code == 0 and json.loads(out) == {"label": "last", "cluster": ids[-1], "primitive": None,
                                             "version": 2}
    code, out, _ = run("library", "label", db, "--primitive", "3", "mine", "--json")
    assert json.loads(out) == {"label": "mine", "cluster": None, "primitive": 3, "version": 2}
    code, out, _ = run("library", "export", db, tmp_path / "exp", "--json")
    assert code == 0 and json.loads(out) == {"folder": str(tmp_path / "exp"),
                                             "manifest": str(tmp_path / "exp" / "manifest.json"),
                                             "demonstrations": 6}
    code, out, _ = run("library", "remove", db, "2", "--json")
    assert code == 0 and json.loads(out) == {"removed": 2, "primitives": [2]}


def test_cluster_plot(run, tmp_path, new_library):
    db, _ = _clustered(run, tmp_path, new_library())
    code, out, err = run("library", "cluster", db, "--plot", tmp_path / "clusters.png")
    assert code == 0, err
    assert (tmp_path / "clusters.png").stat().st_size > 0 and f"wrote {tmp_path / 'clusters.png'}" in out
    code, out, _ = run("library", "cluster", db, "--plot", tmp_path / "again.png", "--json")
    assert json.loads(out)["plot"] == str(tmp_path / "again.png")


@pytest.mark.parametrize("json_flag", [[], ["--json"]])
def test_long_commands_show_progress_on_a_terminal_only(run, tmp_path, new_library, monkeypatch, json_flag):
    import sys

    db, _ = _clustered(run, tmp_path, new_library())
    goal = "0.15,-0.4,1.05"
    commands = [("cluster", db), ("reuse", db, "--skill", "0", "--goal", goal, "--method", "lte"),
                ("export", db, tmp_path / f"exp{len(json_flag)}")]
    for tty in (False, True):
        monkeypatch.setattr(sys.stderr, "isatty", lambda tty=tty: tty)
        for argv in commands:
            if argv[0] == "export":
                argv = (*argv[:-1], tmp_path / f"exp{len(json_flag)}{tty}")
            code, out, err = run("library", *argv, *json_flag)
            assert code == 0, err
            shown = tty and not json_flag
            assert (err != "") is shown, (argv, tty, err)
            if shown:
                assert {"cluster": "clustering", "reuse": "adapting", "export": "exporting"}[argv[0]] in err


def _as_nobody(queue, argvs, become):
    """Run each command as the user nobody (fork, no exec: the interpreter is not readable by nobody)."""
    import contextlib
    import io

    from skillbank.cli import main

    if become:
        os.setgid(become[1])
        os.setuid(become[0])
    results = []
    for argv in argvs:
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main([str(a) for a in argv])
        results.append((code, out.getvalue(), err.getvalue()))
    queue.put(results)


def test_a_library_in_a_read_only_folder_is_readable_by_another_user(run):
    """The lab case: a library in a folder (0o555) that the user may read but not write.

    Tests run as root, which may write anywhere; so the commands run in a child process that
    becomes the user ``nobody`` (skipped where there is no such user).
    """
    import multiprocessing
    import pwd
    import shutil
    import tempfile

    become = None  # a user other than root is refused writing by the folder's mode itself
    if os.geteuid() == 0:
        try:
            nobody = pwd.getpwnam("nobody")
        except KeyError:
            pytest.skip("running as root and there is no user 'nobody' to run the commands as")
        become = (nobody.pw_uid, nobody.pw_gid)
    # under /tmp, not tmp_path: pytest's own folders are closed to other users
    root = Path(tempfile.mkdtemp(prefix="skillbank-ro-", dir="/tmp"))
    try:
        os.chmod(root, 0o755)
        lab, out = root / "lab", root / "out"
        lab.mkdir()
        out.mkdir()
        os.chmod(out, 0o777)
        db, _ = _clustered(run, root)
        shutil.move(db, lab / "skills.db")
        db = lab / "skills.db"
        assert sorted(p.name for p in lab.iterdir()) == ["skills.db"]
        os.chmod(db, 0o444)
        os.chmod(lab, 0o555)
        queue = multiprocessing.get_context("fork").Queue()
        proc = multiprocessing.get_context("fork").Process(target=_as_nobody, args=(queue, [
            ("library", "list", db, "--json"),
            ("library", "reuse", db, "--skill", "0", "--goal", "0.15,-0.4,1.05", "--method", "lte", "--json"),
            ("library", "export", db, out / "copy"),
            ("library", "label", db, "--cluster", "0", "x"),
        ], become))
        proc.start()
        results = queue.get(timeout=120)
        proc.join(30)
        (c1, o1, e1), (c2, o2, e2), (c3, o3, e3), (c4, o4, e4) = results
        assert c1 == 0 and json.loads(o1)["n_demonstrations"] == 6, e1
        assert c2 == 0 and json.loads(o2)["collision"] is False, e2
        assert c3 == 0 and (out / "copy" / "manifest.json").is_file(), e3
        assert c4 == 2 and e4.count("\n") == 1 and "is read-only here (its file or its folder is not " \
            "writable)" in e4, e4
        assert sorted(p.name for p in lab.iterdir()) == ["skills.db"]
    finally:
        for path in (root / "lab", root / "lab" / "skills.db"):
            if path.exists():
                os.chmod(path, 0o755)
        shutil.rmtree(root)
