"""Passwords are never printed, and no connection string is taken for a file (issue 23, item 2); user-given
text reaches the terminal without raw escape sequences (item 8).

Every form a lab writes a connection string in is either opened or refused in one line; the password
(as written, percent-decoded and percent-encoded) appears in no message, exception chain, JSON, progress
bar or log record, and a refused location creates nothing in the working folder.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import secrets as random_secrets
from pathlib import Path
from urllib.parse import quote

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from skillbank import Demonstration
from skillbank.cli._output import error_line
from skillbank.io import write_npz
from skillbank.pipeline import Library
from skillbank.store import SCHEMA_VERSION, PostgresStore, mask_url, open_store
from skillbank.store._registry import parse_location
from skillbank.store._secrets import check_url, scrub, secrets

RESERVED = "?#@/:%&= "
# a loopback port nothing listens on: the driver fails at once, without any network
NOWHERE = "127.0.0.1:1"


def _forms(secret: str) -> set:
    """What must never be shown: the password as written, decoded and encoded."""
    return {secret, quote(secret, safe=""), quote(secret)}


def _chain(exc) -> str:
    """The text of ``exc`` and of every exception it chains (what a traceback or a caller could show)."""
    texts, seen = [], set()
    while exc is not None and id(exc) not in seen:
        seen.add(id(exc))
        texts.append(" ".join(map(str, exc.args)) + " " + str(exc))
        exc = exc.__cause__ or exc.__context__
    return " | ".join(texts)


def _demo_file(folder, name="reach.npz"):
    t = np.linspace(0.0, 1.0, 60)
    return write_npz(Demonstration.from_array(np.column_stack([t, t ** 2, 0 * t]), t), folder / name)


# -- masking: every form, known answers -----------------------------------------------------------
@pytest.mark.parametrize("location, shown", [
    ("postgresql://ann:s3c?ret@db.invalid/skills", "postgresql://ann:***@db.invalid/skills"),
    ("postgresql://ann:s3c#ret@db.invalid/skills", "postgresql://ann:***@db.invalid/skills"),
    ("postgresql://ann:s3c@ret@db.invalid/skills", "postgresql://ann:***@db.invalid/skills"),
    ("postgresql://ann:s3c/ret@db.invalid/skills", "postgresql://ann:***@db.invalid/skills"),
    ("postgresql://ann:s3c:ret@db.invalid/skills", "postgresql://ann:***@db.invalid/skills"),
    ("postgresql://ann:s3c%3Fret@db.invalid/skills", "postgresql://ann:***@db.invalid/skills"),
    ("postgresql://ann:50%off@db.invalid/skills", "postgresql://ann:***@db.invalid/skills"),
    ("postgresql://ann@corp:s3cret@db/skills", "postgresql://ann@corp:***@db/skills"),
    ("postgresql://ann/x:s3cret@db/skills", "postgresql://ann/x:***@db/skills"),  # what a greedy reader takes
    ("postgresql://ann@db/skills?password=s3c&ret&sslmode=disable",
     "postgresql://ann@db/skills?password=***&sslmode=disable"),
    ("postgresql://ann@db/skills?password=s3c#ret", "postgresql://ann@db/skills?password=***"),
    ("postgresql://ann@db/skills?sslpassword=k3y&sslmode=require",
     "postgresql://ann@db/skills?sslpassword=***&sslmode=require"),
    ("postgresql:ann:s3cret@db.invalid/skills", "postgresql:ann:***@db.invalid/skills"),
    ("postgres:ann:s3cret@db.invalid/skills", "postgres:ann:***@db.invalid/skills"),
    ("postgresql:/ann:s3cret@db/skills", "postgresql:***@db/skills"),
    ("ann:s3cret@db.invalid/skills", "ann:***@db.invalid/skills"),
    ("ann:pw:s3cret@db", "ann:***@db"),
    ("postgresql://ann:s3cret@db.invalid/skills\nx", "postgresql://ann:***@db.invalid/skills\nx"),
    (" postgresql://ann:s3cret@db/skills", " postgresql://ann:***@db/skills"),
    ("host=db.invalid password=s3cret dbname=skills", "host=db.invalid password=*** dbname=skills"),
    ("host=db password = 's3 c\\'ret' dbname=skills", "host=db password = *** dbname=skills"),
    ("dbname=skills password='s3 cret", "dbname=skills password=***"),  # an unterminated quote: to the end
    ("./ann:s3cret@db", "./ann:s3cret@db"),  # ./ makes it a file name
    ("runs/lib@2:00.db", "runs/lib@2:00.db"),
])
def test_every_form_of_connection_string_is_masked(location, shown):
    assert mask_url(location) == shown


@pytest.mark.parametrize("location, password", [
    ("postgresql://ann:s3c%3Fret@db/skills", "s3c?ret"),
    ("postgresql://ann:s3c@ret@db/skills", "s3c"),  # libpq's own reading (to the first '@') as well
    ("host=db password='it\\'s' dbname=x", "it's"),
    ("postgresql:ann:s3cret@db/skills", "s3cret"),
    ("postgresql://ann@db/skills?password=a%26b", "a&b"),
])
def test_secrets_lists_the_password_as_any_reader_takes_it(location, password):
    assert password in secrets(location)
    assert password not in scrub(f"the driver said {password!r}", location)


# printable text, reserved characters drawn often; no '*' (the mask's own character)
_TEXT = st.text(st.characters(codec="utf-8", categories=("L", "N", "P", "S", "Zs"), exclude_characters="*")
                | st.sampled_from(RESERVED), max_size=12)
_PASSWORDS = st.builds("{}{}{}".format, _TEXT, st.sampled_from(RESERVED), _TEXT)


@given(_PASSWORDS)
def test_a_percent_encoded_password_of_any_characters_is_accepted_and_never_shown(password):
    frame = "postgresql://ann:***@db.lab:5432/skills?sslmode=require"
    assume(password not in frame)  # a password that is part of the URL's other text is shown there
    url = f"postgresql://ann:{quote(password, safe='')}@db.lab:5432/skills?sslmode=require"
    assert check_url(url) == url  # the driver reads the same password the mask hides
    assert mask_url(url) == frame
    said = 'driver: "***" / "***"'
    assume(not any(form in said for form in _forms(password)))
    message = scrub(f'driver: "{password}" / "{quote(password, safe="")}"', url)
    assert message.startswith('driver: "') and not any(form in message for form in _forms(password))


@given(st.builds("{}{}{}".format, _TEXT, st.sampled_from("@/?#"), _TEXT))
def test_a_raw_password_with_a_reserved_character_is_refused_with_the_same_masked_line(password):
    def refusal(secret):
        with pytest.raises(ValueError) as err:
            check_url(f"postgresql://ann:{secret}@db.lab:5432/skills")
        return str(err.value)

    expected = refusal("s3c?ret")
    assume(not any(form in expected for form in _forms(password)))  # e.g. '/' is in the message's own text
    assert refusal(password) == expected
    assert expected.startswith("library 'postgresql://ann:***@db.lab:5432/skills': cannot tell the password")


# -- refused forms: one line, masked, nothing created --------------------------------------------
@pytest.mark.parametrize("location, says", [
    ("postgresql://ann:s3c?ret@{}/skills", r"cannot tell the password from the rest .*'\?' as %3F"),
    ("postgresql://ann:s3c#ret@{}/skills", r"cannot tell the password .*'#' as %23"),
    ("postgresql://ann:s3c@ret@{}/skills", r"cannot tell the password .*'@' as %40"),
    ("postgresql://ann:s3c/ret@{}/skills", r"cannot tell the password .*'/' as %2F"),
    ("postgresql://ann:s3c%ret@{}/skills", r"a '%' in the user part is not followed by two hex digits.*%25"),
    ("postgresql://ann@{}/skills?password=s3c&ret", r"a query parameter without '='.*'&' as %26"),
    ("postgresql:ann:s3cret@{}/skills", r"a URL without '//' after its scheme; write "
                                        r"postgresql://ann:\*\*\*@127\.0\.0\.1:1/skills"),
    ("postgres:ann:s3cret@{}/skills", r"write postgres://ann:\*\*\*@"),
    ("postgresql:/ann:s3cret@{}/skills", r"write postgresql://ann:\*\*\*@"),
    ("ann:s3cret@{}/skills", r"reads as user:password@host, a URL without its scheme; write "
                             r"postgresql://ann:\*\*\*@127\.0\.0\.1:1/skills \(or start it with \./"),
    ("postgresql://ann:s3cret@{}/skills\nx", r"holds no control characters \(a newline, NUL or escape"),
    ("postgresql://ann:s3cret@{}/skills\x00", r"holds no control characters"),
    ("lib\x1b[2J.db", r"^library 'lib\\x1b\[2J\.db': a path or URL holds no control characters"),
    (" postgresql://ann:s3cret@{}/skills", r"a URL starts with its scheme .*remove what comes before it"),
    ("host={} password=s3cret dbname=skills", r"a libpq keyword string is not a library location; write it "
                                              r"as a URL, postgresql://user:password@host"),
    ("dbname=skills password='s3 cret'", r"a libpq keyword string"),
    ("sqlite://ann:s3cret@{}/skills", r"reads as user:password@host"),
    ("sqlite:ann:s3cret@{}", r"write sqlite:///ann:"),
])
def test_a_connection_string_in_another_form_is_refused_in_one_masked_line(tmp_path, monkeypatch,
                                                                            location, says):
    monkeypatch.chdir(tmp_path)
    location = location.replace("{}", NOWHERE)
    with pytest.raises(ValueError, match=says) as err:
        open_store(location)
    message = _chain(err.value)
    assert "\n" not in str(err.value) and "\x1b" not in str(err.value) and "\x00" not in str(err.value)
    for secret in ("s3cret", "s3c?ret", "s3c#ret", "s3c@ret", "s3c/ret", "s3c%ret", "s3c&ret", "s3 cret"):
        assert secret not in message
    assert os.listdir(tmp_path) == []


def test_postgres_store_itself_takes_only_a_url(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for location in ("host=db password=s3cret dbname=skills", "ann:s3cret@db/skills"):
        with pytest.raises(ValueError, match=r"^library '.*\*\*\*.*': expected a URL postgresql://") as err:
            PostgresStore(location)
        assert "s3cret" not in _chain(err.value)
    assert os.listdir(tmp_path) == []


def test_a_path_with_a_control_character_is_refused_as_a_path_too(tmp_path):
    with pytest.raises(ValueError, match=r"^library '.*lib\\nx\.db': a path or URL holds no control char"):
        open_store(tmp_path / "lib\nx.db")
    with pytest.raises(ValueError, match=r"^library: expected a path or a URL, got '  '$"):
        open_store("  ")
    assert os.listdir(tmp_path) == []


def test_a_credential_shape_too_long_for_a_file_name_is_refused_masked(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    password = "s3cret" * 100  # longer than a file name may be: asking whether it exists fails
    with pytest.raises(ValueError, match=r"^library 'ann:\*\*\*@db/skills' reads as user:password@host"):
        open_store(f"ann:{password}@db/skills")
    assert os.listdir(tmp_path) == []


def test_forms_that_are_files_stay_files(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert parse_location("./ann:s3cret@db") == ("sqlite", Path("ann:s3cret@db"))
    (tmp_path / "run:2@lab.db").touch()  # an existing file of that shape is that file
    assert parse_location("run:2@lab.db")[0] == "sqlite"
    assert parse_location("runs@2:00.db")[0] == "sqlite"  # the ':' after the '@': no credentials
    assert parse_location("POSTGRESQL://ann@db/skills") == ("postgresql", "POSTGRESQL://ann@db/skills")
    assert check_url("POSTGRESQL://ann@db/skills") == "postgresql://ann@db/skills"  # libpq wants lower case


@pytest.mark.parametrize("password", ["s3c?ret", "s3c#ret", "s3c@ret", "s3c/ret", "s3c:ret", "50%off",
                                      "a&b=c", "sp ace", "ünï©ode"])
def test_percent_encoded_passwords_reach_the_driver_and_are_masked_in_its_failure(password):
    pytest.importorskip("psycopg")
    url = f"postgresql://ann:{quote(password, safe='')}@{NOWHERE}/skills"
    with pytest.raises(ValueError, match=r"^library 'postgresql://ann:\*\*\*@127\.0\.0\.1:1/skills': cannot "
                                         r"connect: .*Connection refused") as err:
        PostgresStore(url)
    text = _chain(err.value)
    assert not any(form in text for form in _forms(password)), text
    assert err.value.__cause__ is None and err.value.__context__ is None  # no driver exception chained


def test_the_error_line_escapes_and_masks_what_it_prints():
    args = argparse.Namespace(db=type("U", (), {"url": "postgresql://ann:s3cret@db/skills"})())
    shown = error_line(ValueError("the server said 's3cret'\x1b[2J\n"), args)
    assert shown == r"the server said '***'\x1b[2J"


# -- the command line ----------------------------------------------------------------------------
def test_usage_errors_are_masked_and_escaped_on_stderr(capsys, tmp_path):
    from skillbank.cli._main import main  # as above

    with pytest.raises(SystemExit) as done:  # argparse quotes the arguments it did not expect
        main(["library", "list", str(tmp_path / "lib.db"), "postgresql://ann:s3cret@db/skills",
              "host=db password=s3cret", "\x1b[2J"])
    err = capsys.readouterr().err
    assert done.value.code == 2 and os.listdir(tmp_path) == []
    assert err == ("skillbank: error: unrecognized arguments: postgresql://ann:***@db/skills "
                   "host=db password=*** \\x1b[2J\n")

_FORMS = [
    "postgresql://ann:s3c?ret@127.0.0.1:1/skills",
    "postgresql://ann:s3c#ret@127.0.0.1:1/skills",
    "postgresql://ann:s3c@ret@127.0.0.1:1/skills",
    "postgresql://ann:s3c/ret@127.0.0.1:1/skills",
    "postgresql://ann:s3c%ret@127.0.0.1:1/skills",
    "postgresql://ann:s3c%3Fret@127.0.0.1:1/skills",   # encoded: reaches the driver, refused connection
    "postgresql://ann:s3c%40ret@127.0.0.1:1/skills",
    "postgresql://ann:s3c:ret@127.0.0.1:1/skills",
    "postgresql://ann@127.0.0.1:1/skills?password=s3c%26ret",
    "postgresql:ann:s3cret@127.0.0.1:1/skills",
    "postgres:ann:s3cret@127.0.0.1:1/skills",
    "ann:s3cret@127.0.0.1:1/skills",
    "postgresql://ann:s3cret@127.0.0.1:1/skills\nx",
    "host=127.0.0.1 port=1 password=s3cret dbname=skills",
    "dbname=skills password='s3 cret'",
    " postgresql://ann:s3cret@127.0.0.1:1/skills",
]


@pytest.mark.parametrize("form", _FORMS)
@pytest.mark.parametrize("command", [("list",), ("list", "--json"), ("init",), ("init", "--json"),
                                     ("add", "FILE", "--json"), ("copy", "SRC"), ("copy", "DST")])
def test_every_form_on_the_command_line_is_one_line_with_nothing_shown_or_created(cli, tmp_path, monkeypatch,
                                                                                   form, command):
    pytest.importorskip("psycopg")
    work = tmp_path / "cwd"
    work.mkdir()
    demo = _demo_file(tmp_path)
    monkeypatch.chdir(work)
    name, *rest = command
    if name == "copy" and rest == ["SRC"]:
        argv = [form, "out.db"]
    elif name == "copy":
        Library(tmp_path / "src.db").close()
        argv = [str(tmp_path / "src.db"), form]
    else:
        argv = [form, *(str(demo) if w == "FILE" else w for w in rest)]
    before = sorted(os.listdir(work))
    code, out, err = cli("library", name, *argv)
    assert code == 2 and out == "" and err.count("\n") == 1, (out, err)
    assert err.startswith(f"skillbank library {name}: error: "), err
    for secret in ("s3cret", "s3c?ret", "s3c#ret", "s3c@ret", "s3c/ret", "s3c%ret", "s3c:ret", "s3c&ret",
                   "s3c%3Fret", "s3c%40ret", "s3c%26ret", "s3 cret"):
        assert secret not in err, err
    assert sorted(os.listdir(work)) == before


# -- terminal escapes in what the library holds --------------------------------------------------
def test_labels_with_terminal_escapes_are_shown_escaped_and_json_stays_exact(cli, tmp_path):
    db = tmp_path / "lib.db"
    red, csi = "\x1b[31mred\x1b[0m", "clear\x9b2J\x07"
    with Library(db) as lib:
        t = np.linspace(0.0, 1.0, 40)
        demos = [Demonstration.from_array(np.column_stack([t, k * t]), t) for k in (1, 2)]
        lib.add_many(demos, segment=False)
        first, second = (p.id for p in lib.primitives(load=False))
        lib.label(red, primitive=first)
        lib.label(csi, primitive=second)
    code, out, err = cli("library", "list", db)
    assert code == 0, err
    assert "\x1b" not in out and "\x9b" not in out and "\x07" not in out
    assert r"label \x1b[31mred\x1b[0m (given)," in out and r"label clear\x9b2J\x07 (given)," in out
    code, out, err = cli("library", "list", db, "--json")
    assert code == 0 and "\x1b" not in out and "\x9b" not in out
    assert [p["label"] for p in json.loads(out)["primitives"]] == [red, csi]


def test_a_file_name_with_an_escape_is_shown_escaped_when_skipped(cli, tmp_path):
    db, bad = tmp_path / "lib.db", tmp_path / "bad\x1b[2J.npz"
    assert cli("library", "init", db)[0] == 0
    code, out, err = cli("library", "add", db, _demo_file(tmp_path), bad, "--keep-going", "--whole")
    assert code == 2 and "\x1b" not in err and r"bad\x1b[2J.npz" in err, err


# -- a real server, a password with every reserved character --------------------------------------
@pytest.fixture
def reserved_role(postgres_server, postgres_url):
    """A role owning the test database, its password holding every reserved character: (url, password)."""
    dbname = postgres_url.rsplit("/", 1)[1]
    role, password = f"ann_{random_secrets.token_hex(4)}", "s3c?r#e@t/:%x&y= z"
    with postgres_server.admin() as conn:
        conn.execute(f"CREATE ROLE {role} LOGIN PASSWORD '{password}'")
        conn.execute(f"ALTER DATABASE {dbname} OWNER TO {role}")
    port = postgres_server.port
    yield f"postgresql://{role}:{quote(password, safe='')}@127.0.0.1:{port}/{dbname}", password
    with postgres_server.admin() as conn:
        conn.execute(f"DROP DATABASE IF EXISTS {dbname} WITH (FORCE)")
        conn.execute(f"DROP ROLE {role}")


def test_a_server_library_with_a_reserved_password_never_shows_it(cli, tmp_path, monkeypatch, caplog,
                                                                  reserved_role):
    url, password = reserved_role
    shown = url.replace(quote(password, safe=""), "***")
    caplog.set_level(logging.DEBUG)
    monkeypatch.setattr("skillbank.cli._library.show_progress", lambda args: True)  # progress bars drawn
    monkeypatch.chdir(tmp_path)
    printed = []

    def run(*argv, expect=0):
        code, out, err = cli(*argv)
        assert code == expect, err
        printed.append(out + err)
        return out

    assert json.loads(run("library", "init", url, "--json")) == {"library": shown, "created": True,
                                                                 "schema_version": SCHEMA_VERSION}
    assert run("library", "init", url) == f"{shown}: library already exists\n"
    run("library", "add", url, _demo_file(tmp_path), "--whole", "--label", "reach")
    assert [p["label"] for p in json.loads(run("library", "list", url, "--json"))["primitives"]] == ["reach"]
    assert run("library", "list", url).startswith(f"{shown}: 1 demonstration(s), 1 primitive(s)\n")
    copy = json.loads(run("library", "copy", url, tmp_path / "back.db", "--json"))
    assert copy["source"] == shown and copy["demonstrations"] == 1
    run("library", "label", url.replace("%3F", "%3f"), "--primitive", "1", "push")  # either case of hex
    wrong = url.replace(quote(password, safe=""), quote(password[::-1], safe=""))
    run("library", "list", wrong, expect=2)
    assert "password authentication failed" in printed[-1] and printed[-1].count("\n") == 1
    with open_store(url) as store:
        assert store.location == shown and shown in repr(store)
    with pytest.raises(ValueError, match="password authentication failed") as err:
        open_store(wrong)
    printed.append(_chain(err.value))
    everything = "\n".join(printed) + caplog.text
    for secret in (password, password[::-1]):
        assert not any(form in everything for form in _forms(secret))
