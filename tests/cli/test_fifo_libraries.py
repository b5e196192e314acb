"""A FIFO, a device or a socket given as a library is refused by every command, before any work (41)."""

from __future__ import annotations

import os
import socket
import stat

import pytest

from skillbank.cli._main import build_parser, leaf_parsers
from skillbank.store import open_store

LIBRARY_ARGUMENTS = ("db", "src", "dst")


def _library_commands():
    out = []
    for name, parser in sorted(leaf_parsers(build_parser()).items()):
        actions = [a for a in parser._actions if a.dest != "help"]
        if not any(a.dest in LIBRARY_ARGUMENTS for a in actions):
            continue
        for which in [a.dest for a in actions if a.dest in LIBRARY_ARGUMENTS]:
            argv = name.split()[1:]
            for a in actions:
                if not a.option_strings:
                    argv.append("{lib}" if a.dest == which else ("new.db" if a.dest in LIBRARY_ARGUMENTS
                                                                  else "1"))
                elif a.required:
                    argv += [a.option_strings[0], "1"]
            for group in parser._mutually_exclusive_groups:  # --cluster | --primitive, --out | --serve
                if group.required:
                    first = group._group_actions[0]
                    argv += [first.option_strings[0]] + (["1"] if first.nargs != 0 else [])
            out.append(pytest.param(argv, id=f"{name} ({which})"))
    return out


COMMANDS = _library_commands()


def test_every_library_command_is_covered():
    names = {" ".join(p.values[0][:2]) for p in COMMANDS}
    assert {"plan 1", "sim evaluate", "library view", "library add", "library copy"} <= {
        n if not n.startswith("plan") else "plan 1" for n in names}


@pytest.mark.parametrize("argv", COMMANDS)
def test_a_fifo_as_the_library_is_one_line_and_exit_2(argv, cli, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    os.mkfifo("lib.db")
    code, out, err = cli(*[a.format(lib="lib.db") for a in argv])
    assert code == 2 and out == ""
    assert err.count("\n") == 1, err
    assert "error: library 'lib.db': expected a regular file (a SQLite library), got a FIFO (named pipe); " \
           "give the path of a library file" in err
    assert sorted(os.listdir()) == ["lib.db"] and stat.S_ISFIFO(os.lstat("lib.db").st_mode)


@pytest.mark.parametrize("argv", [p for p in COMMANDS if p.values[0][:2] in (["library", "list"],
                                                                              ["library", "add"])])
def test_a_device_and_a_link_to_a_fifo_are_refused_too(argv, cli, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    os.mkfifo("pipe")
    os.symlink("pipe", "link.db")
    for lib, kind in (("/dev/null", "a character device"), ("link.db", "a FIFO")):
        code, out, err = cli(*[a.format(lib=lib) for a in argv])
        assert code == 2 and err.count("\n") == 1 and f"got {kind}" in err, err


@pytest.mark.parametrize("kind", ["fifo", "socket", "device"])
def test_the_store_refuses_them_when_opened_from_python(kind, tmp_path):
    path = tmp_path / "lib.db"
    sock = None
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "socket":
        sock = socket.socket(socket.AF_UNIX)
        sock.bind(str(path))
    else:
        path = "/dev/zero"
    try:
        for options in ({}, {"readonly": True}, {"create": False}):
            with pytest.raises(ValueError, match=r"^library '.*': expected a regular file \(a SQLite "
                                                 r"library\), got a (FIFO|socket|character device)"):
                open_store(path, **options)
    finally:
        if sock is not None:
            sock.close()
