"""``library init`` on an existing library: deliberate, documented idempotence (issue 44).

A script may run ``init`` before every ``add``; the existing library is
checked and left as it is, with status 0, as ``library init --help`` says.
What is not a library still fails with status 2 and one line.
"""

from __future__ import annotations

import numpy as np
import pytest

from skillbank.cli._main import main


def test_init_again_leaves_the_library_as_it_is_and_says_so(cli, tmp_path, library_content):
    db = tmp_path / "lib.db"
    assert cli("library", "init", db) == (0, f"created library {db}\n", "")
    t = np.linspace(0.0, 1.0, 40)
    csv = tmp_path / "a.csv"
    np.savetxt(csv, np.c_[t, t, 0.5 * t], delimiter=",", header="t,position_0,position_1", comments="")
    assert cli("library", "add", db, csv, "--whole")[0] == 0
    before = library_content(db)
    assert cli("library", "init", db) == (0, f"{db}: library already exists\n", "")
    assert library_content(db) == before


def test_the_help_says_init_may_be_run_again(capsys):
    with pytest.raises(SystemExit, match="0"):
        main(["library", "init", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "an existing library is checked and left as it is, with status 0 (init may be run again)" in text


def test_a_file_that_is_no_library_is_refused_in_one_line(cli, tmp_path):
    junk = tmp_path / "notes.db"
    junk.write_text("not a database\n")
    code, out, err = cli("library", "init", junk)
    assert code == 2 and out == "" and err.count("\n") == 1 and "not a SQLite file" in err
    assert junk.read_text() == "not a database\n"
