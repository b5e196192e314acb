"""``skillbank library`` on a postgresql:// URL, through the real entry point: the same answers as on a
file, ``library copy`` both ways, and one clear line with exit status 2 when the server cannot be used."""

from __future__ import annotations

import json

import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.io import write_npz


def _files(folder, n=6):
    """Two kinds of 3-D reach, straight and bowed, as NPZ files."""
    paths = []
    for k in range(n):
        t = np.linspace(0.0, 1.0, 120)
        s = 10 * t ** 3 - 15 * t ** 4 + 6 * t ** 5
        bow = 0.5 * np.sin(np.pi * s) if k % 2 else 0.0 * s
        Y = np.column_stack([s * (1.0 + 0.03 * k), 0.4 * s + 0.02 * k, bow])
        paths.append(write_npz(Demonstration.from_array(Y, t), folder / f"reach{k}.npz"))
    return paths


def _session(cli, db, files):
    """The same commands on ``db``; returns their JSON answers."""
    out = {}
    code, text, err = cli("library", "init", db, "--json")
    assert code == 0, err
    out["init"] = json.loads(text)
    code, text, err = cli("library", "add", db, *files, "--whole", "--json")
    assert code == 0, err
    out["add"] = json.loads(text)
    code, text, err = cli("library", "cluster", db, "--seed", "0", "--json")
    assert code == 0, err
    out["cluster"] = json.loads(text)
    assert cli("library", "label", db, "--cluster", "0", "reach")[0] == 0
    code, text, err = cli("library", "list", db, "--json")
    assert code == 0, err
    out["list"] = json.loads(text)
    code, text, err = cli("library", "reuse", db, "--skill", "reach", "--start", "0,0,0", "--goal",
                          "1.1,0.5,0.0", "--method", "lte", "--json")
    assert code == 0, err
    out["reuse"] = json.loads(text)
    return out


def test_a_postgres_library_answers_as_a_file_does(cli, tmp_path, postgres_server, postgres_url):
    files, shown = _files(tmp_path), postgres_url.replace(postgres_server.password, "***")
    on_file, on_server = _session(cli, tmp_path / "lib.db", files), _session(cli, postgres_url, files)
    assert on_server["init"] == {"library": shown,
                                 "created": True, "schema_version": on_file["init"]["schema_version"]}
    for key in ("add", "cluster", "list", "reuse"):
        assert on_server[key] == on_file[key], key
    assert len(on_server["list"]["skills"]) == 2 and on_server["reuse"]["collision"] is False
    code, text, err = cli("library", "init", postgres_url)  # an existing library is left as it is
    assert code == 0 and text == f"{shown}: library already exists\n"
    code, text, err = cli("library", "list", postgres_url)
    assert code == 0 and "6 demonstration(s), 6 primitive(s)" in text
    assert postgres_server.password not in text + err


def test_library_copy_both_ways_through_the_cli(cli, tmp_path, postgres_server, postgres_url):
    files = _files(tmp_path, n=4)
    src = tmp_path / "src.db"
    _session(cli, src, files)
    code, text, err = cli("library", "copy", src, postgres_url, "--json")
    assert code == 0, err
    shown = postgres_url.replace(postgres_server.password, "***")
    assert json.loads(text) == {"source": str(src), "destination": shown, "demonstrations": 4,
                                "primitives": 4, "versions": 1}
    code, text, err = cli("library", "copy", postgres_url, f"sqlite:///{tmp_path / 'back.db'}")
    assert code == 0, err
    assert text.startswith(f"{tmp_path / 'back.db'}: copied 4 demonstration(s), 4 primitive(s) and 1 "
                           "clustering version(s) from postgresql://skillbank:***@127.0.0.1:")
    lists = [json.loads(cli("library", "list", db, "--json")[1])
             for db in (src, postgres_url, tmp_path / "back.db")]
    assert lists[0] == lists[1] == lists[2]
    code, text, err = cli("library", "copy", src, postgres_url)
    assert code == 2 and text == "" and err.count("\n") == 1
    assert err.startswith("skillbank library copy: error: destination: expected an empty library, "
                          "'postgresql://skillbank:***@")
    code, _, err = cli("library", "copy", tmp_path / "missing.db", tmp_path / "x.db")
    assert code == 2 and "does not exist" in err and not (tmp_path / "x.db").exists()


@pytest.mark.parametrize("command", [("list",), ("init",), ("add", "x.npz"), ("copy", "SERVER", "out.db")])
def test_server_failures_exit_2_with_one_masked_line(cli, tmp_path, postgres_server, command):
    port, password = postgres_server.port, postgres_server.password
    for url, says in [
        (f"postgresql://skillbank:{password}@127.0.0.1:{port}/x?nonsense=1", "invalid URI query parameter"),
        (f"postgresql://skillbank:{password}@127.0.0.1:notaport/x", 'invalid integer value "notaport"'),
        (f"postgresql://skillbank:{password}@127.0.0.1:1/x", "Connection refused"),
        (f"postgresql://skillbank:Wr0ng-{password[:4]}@127.0.0.1:{port}/postgres",
         'password authentication failed for user "skillbank"'),
    ]:
        argv = [w.replace("x.npz", str(tmp_path / "x.npz")).replace("out.db", str(tmp_path / "out.db"))
                for w in command]
        argv = [url if w == "SERVER" else w for w in argv]
        code, out, err = cli("library", argv[0], *([] if argv[0] == "copy" else [url]), *argv[1:])
        assert code == 2 and out == "" and err.count("\n") == 1, err
        prefix = f"skillbank library {argv[0]}: error: library 'postgresql://skillbank:***@"
        assert err.startswith(prefix), err
        assert says in err and password not in err and f"Wr0ng-{password[:4]}" not in err, err
    assert not (tmp_path / "out.db").exists()
