"""``skillbank library``: the end-to-end loop on real RAIL data, output shapes and error exits."""

from __future__ import annotations

import json
import sqlite3

import numpy as np
import pytest


@pytest.fixture
def run(cli):
    return cli


def test_end_to_end_on_rail(run, tmp_path, data_dir):
    db, rail = tmp_path / "skills.db", data_dir / "rail"
    assert run("library", "init", db)[0] == 0
    code, out, err = run("library", "add", db, rail / "REACHING" / "1.mat", rail / "REACHING" / "2.mat",
                         "--whole", "--label", "reaching", "--json")
    assert code == 0, err
    added = json.loads(out)
    assert len(added["demonstrations"]) == 12 and all(len(p) == 1 for p in added["primitives"])
    assert "adding" in err  # the tqdm progress bar
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
    assert set(doc) == {"n_demonstrations", "skills", "primitives"} and doc["n_demonstrations"] == 18
    assert doc["skills"][0] == {"cluster": 0, "label": "first", "count": doc["skills"][0]["count"]}
    assert set(doc["primitives"][0]) == {"id", "demonstration", "cluster", "label", "n_steps"}
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


def test_export_import_remove_and_text_output(run, tmp_path):
    from skillbank import Demonstration
    from skillbank.io import write_npz

    t = np.linspace(0.0, 1.0, 40)
    for k in range(3):
        write_npz(Demonstration.from_array(np.column_stack([t, k * t]), t), tmp_path / f"d{k}.npz")
    db = tmp_path / "a.db"
    files = [tmp_path / f"d{k}.npz" for k in range(3)]
    code, out, err = run("library", "add", db, *files, "--whole")
    assert code == 2 and "does not exist" in err  # no implicit creation outside init
    run("library", "init", db)
    code, out, err = run("library", "add", db, *files, "--whole")
    assert code == 0 and "added 3 demonstration(s) with 3 primitive(s)" in out
    assert run("library", "label", db, "--primitive", "2", "slope")[0] == 0
    code, out, _ = run("library", "export", db, tmp_path / "exp")
    assert code == 0 and (tmp_path / "exp" / "manifest.json").exists()
    code, out, _ = run("library", "import", tmp_path / "b.db", tmp_path / "exp", "--json")
    assert code == 0 and json.loads(out)["demonstrations"] == {"1": 1, "2": 2, "3": 3}
    assert json.loads(run("library", "list", tmp_path / "b.db", "--json")[1]) == \
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
        (("library", "list", tmp_path / "none.db"), "does not exist"),
    ]:
        code, out, err = run(*argv)
        assert code == 2 and match in err and err.count("\n") == 1, (argv, err)
        assert err.startswith("skillbank library: error:")
    db = tmp_path / "ok.db"
    run("library", "init", db)
    code, _, err = run("library", "label", db, "--cluster", "0", "x")
    assert code == 2 and "no clusters yet" in err
    code, _, err = run("library", "reuse", db, "--skill", "x", "--start", "0,nope")
    assert code == 2 and "start: expected a number" in err
    code, _, err = run("library", "reuse", db, "--skill", "x", "--start", "0,0")
    assert code == 2 and "no primitive has label 'x'" in err


def test_reuse_accepts_negative_coordinates(run, tmp_path):
    from skillbank import Demonstration
    from skillbank.io import write_npz

    t = np.linspace(0.0, 1.0, 60)
    files = []
    for k in range(3):
        path = tmp_path / f"arc{k}.npz"
        write_npz(Demonstration.from_array(np.column_stack([t, np.sin(np.pi * t) * (1 + 0.1 * k)]), t), path)
        files.append(path)
    db = tmp_path / "neg.db"
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
