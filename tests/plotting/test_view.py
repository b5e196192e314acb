"""The web view without a browser: its pages, escaping, the written site, the server and the command."""

from __future__ import annotations

import http.client
import io
import json
import os
import signal
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from skillbank import Demonstration
from skillbank.pipeline import Library
from skillbank.plotting._view import MARKER, LibraryView, write_view
from skillbank.plotting._view_html import script_json, text
from skillbank.plotting._view_server import ViewServer, parse_address
from skillbank.store import open_store
from skillbank.store._secrets import secrets

from .conftest import HOSTILE

REPO = Path(__file__).resolve().parents[2]


@given(st.recursive(st.text() | st.integers() | st.floats(allow_nan=False, allow_infinity=False) | st.none(),
                    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(), inner, max_size=4),
                    max_leaves=20))
def test_embedded_json_has_no_raw_markup_and_reads_back(value):
    out = script_json(value)
    assert not set(out) & {"<", ">", "&", "\u2028", "\u2029"}
    assert json.loads(out) == value


def test_text_escapes_markup_and_quotes():
    assert text('<a href="x">&\'') == "&lt;a href=&quot;x&quot;&gt;&amp;&#x27;"


@pytest.fixture(scope="module")
def written(view_library, tmp_path_factory):
    out = tmp_path_factory.mktemp("written") / "site"
    with Library(view_library["path"], readonly=True) as lib:
        done = write_view(lib, out, page_size=4)
    return out, done


def test_the_site_holds_every_page_and_its_own_assets(written, view_library):
    out, done = written
    summary = view_library["summary"]
    names = {p.name for p in out.iterdir()}
    skills = {f"skill-{s['cluster']}.html" for s in summary["skills"]}
    demos = {f"demonstration-{d}.html" for d in range(1, summary["n_demonstrations"] + 1)}
    assert skills | demos | {"index.html", "planning.html", "demonstrations.html", "assets", MARKER} <= names
    assert f"skill-{view_library['straight']}-2.html" in names  # 6 members, 4 a page
    assert done["pages"] == len([n for n in names if n.endswith(".html")])
    assert sorted(p.name for p in (out / "assets").iterdir()) == ["plotly.min.js", "view.css", "view.js"]
    # no page loads anything but the site's own assets: no URL with a scheme or a host anywhere
    for page in out.glob("*.html"):
        html = page.read_text()
        sources = {s for s in _attributes(html, "src")} | {s for s in _attributes(html, "href")}
        assert all("//" not in s and not s.startswith("/") for s in sources if s != "data:,"), (page, sources)


def _attributes(html: str, name: str) -> list:
    import re

    return re.findall(rf'\b{name}="([^"]*)"', html)


def test_no_page_holds_the_hostile_text_raw(written):
    out, _ = written
    for page in out.glob("*.html"):
        raw = page.read_text()
        for bad in (HOSTILE, "<script>alert", "</pre><script>"):
            assert bad not in raw, (page.name, bad)
    index = (out / "index.html").read_text()
    assert "&lt;img src=x onerror=alert(1)&gt;" in index


@pytest.mark.parametrize("name", ["skill-99.html", "skill-0-1.html", "skill-0-9.html",
                                  "demonstration-999.html", "demonstrations-5.html", "../index.html",
                                  "index.htm", "skill--1.html",
                                  "assets/view.js", "unassigned-2.html", "skill-0.html/x"])
def test_an_unknown_page_is_none(view_library, name):
    with Library(view_library["path"], readonly=True) as lib:
        assert LibraryView(lib, page_size=4).render(name) is None


def test_a_label_carried_by_a_reclustering_is_inferred(tmp_path, view_library):
    path = tmp_path / "copy.db"
    path.write_bytes(view_library["path"].read_bytes())
    with Library(path) as lib:
        lib.cluster()
        html = LibraryView(lib).render("index.html")
    hostile = "&lt;img src=x onerror=alert(1)&gt;"
    assert f'{hostile}</span> <span class="note">(given, carried from version 1)' in html
    assert "clustering version 2" in html and "<h2>Clustering versions</h2>" in html


def test_unclustered_primitives_have_their_page(tmp_path):
    t = np.linspace(0.0, 1.0, 30)
    with open_store(tmp_path / "lib.db") as store:
        store.add_demonstration(Demonstration.from_array(np.c_[t, t, t], t), [(0, 10), (10, 30)])
        view = LibraryView(store, page_size=1)
        assert {"unassigned.html", "unassigned-2.html"} <= set(view.pages())
        index, second = view.render("index.html"), view.render("unassigned-2.html")
    assert "no clustering yet" in index and "2 primitive(s) in no cluster" in index
    assert "<td>2</td>" in second and "page 2 of 2" in second


def test_a_view_replaces_only_a_view(tmp_path, view_library):
    with Library(view_library["path"], readonly=True) as lib:
        out = tmp_path / "site"
        write_view(lib, out)
        (out / "stale.html").write_text("old")
        write_view(lib, out)  # a view written before is replaced whole
        assert not (out / "stale.html").exists() and (out / "index.html").is_file()
        other = tmp_path / "mine"
        other.mkdir()
        (other / "notes.txt").write_text("keep")
        with pytest.raises(ValueError, match=r"out: folder .*mine' is not empty and holds no skillbank view"):
            write_view(lib, other)
        with pytest.raises(ValueError, match=r"out: .*notes.txt' exists and is not a folder"):
            write_view(lib, other / "notes.txt")
        with pytest.raises(ValueError, match=r"out: folder .*nowhere' does not exist"):
            write_view(lib, tmp_path / "nowhere" / "site")
        with pytest.raises(ValueError, match=r"page_size: expected"):
            write_view(lib, tmp_path / "new", page_size=0)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine", "site"]  # no temporary folder left
    assert (other / "notes.txt").read_text() == "keep"


def test_a_page_that_fails_leaves_the_folder_as_it_was(tmp_path, view_library, monkeypatch):
    with Library(view_library["path"], readonly=True) as lib:
        out = tmp_path / "site"
        write_view(lib, out)
        before = sorted(p.name for p in out.iterdir())
        real = LibraryView.render

        def broken(self, name):
            if name == "planning.html":
                raise ValueError("planning: the store failed")
            return real(self, name)

        monkeypatch.setattr(LibraryView, "render", broken)
        with pytest.raises(ValueError, match="planning: the store failed"):
            write_view(lib, out)
        with pytest.raises(ValueError, match="planning: the store failed"):
            write_view(lib, tmp_path / "fresh")
    assert sorted(p.name for p in out.iterdir()) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["site"]


# -- a large library ----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def large_library(tmp_path_factory):
    """10^4 primitives in 100 demonstrations, in a clustering of 4 skills (written through the store)."""
    path = tmp_path_factory.mktemp("large") / "large.db"
    rng = np.random.default_rng(0)
    t = np.linspace(0.0, 10.0, 1000)
    with open_store(path) as store:
        walks = [np.cumsum(rng.normal(size=(1000, 3)), axis=0) * 0.01 for _ in range(100)]
        store.add_demonstrations([{"demo": Demonstration(t, {"position": Y}),
                                   "bounds": [(10 * k, 10 * k + 10) for k in range(100)]} for Y in walks])
        prims = store.primitives(load=False)
        clusters = np.arange(len(prims)) % 4
        X = rng.normal(size=(len(prims), 3)) + 10.0 * clusters[:, None]
        params = {"method": "ElasticClustering", "min_separation": 4.0, "features": "default"}
        centers = 10.0 * np.repeat(np.arange(4.0)[:, None], 3, axis=1)
        store.add_version(params=params, centers=centers, pca_mean=np.zeros(3), pca_components=np.eye(3),
                          labels={0: "zero"},
                          members=[(p.id, int(c), x) for p, c, x in zip(prims, clusters, X, strict=True)])
    return path


def test_a_page_of_a_large_skill_reads_only_its_own_members_samples(large_library, monkeypatch):
    """10^4 primitives: the index reads no samples, a skill page only its members' demonstrations, so a
    page costs the same however large the skill (benchmarks/bench_view.py times it: 0.26 s here)."""
    read = []
    with open_store(large_library, readonly=True) as store:
        real = store.demonstrations
        monkeypatch.setattr(store, "demonstrations", lambda ids: read.append(sorted(ids)) or real(ids))
        view = LibraryView(store)
        index = view.render("index.html")
        assert read == [] and "10000 primitive(s)" in index and index.count("<tr>") == 1 + 4
        last = view.render("skill-0-25.html")
        members = store.primitives(cluster=0, load=False)[2400:]  # every 4th: 4 demonstrations
        assert read == [sorted({p.demonstration_id for p in members})] and len(read[0]) == 4
        assert view.render("skill-0-26.html") is None  # 2500 members, 100 a page
    assert last.count('"type": "scatter3d"') == 100 and "page 25 of 25" in last
    assert all(f"<td>{p.id}</td>" in last for p in members)


# -- the server -----------------------------------------------------------------------------------------
@pytest.fixture
def server(view_library):
    log = io.StringIO()
    with ViewServer(lambda: Library(view_library["path"], readonly=True), page_size=4, log=log) as s:
        s.start()
        s.log_text = log
        yield s


def _raw(server, request: bytes) -> tuple[int, dict, bytes]:
    """Send ``request`` as it is (no client normalises its path) and read the whole answer."""
    with socket.create_connection(("127.0.0.1", server.port), timeout=10) as sock:
        sock.sendall(request)
        data = b""
        while chunk := sock.recv(65536):
            data += chunk
    head, _, body = data.partition(b"\r\n\r\n")
    lines = head.decode("latin-1").split("\r\n")
    headers = dict(line.split(": ", 1) for line in lines[1:])
    return int(lines[0].split()[1]), headers, body


def test_the_server_answers_its_own_pages_to_get_and_head(server):
    status, headers, body = _raw(server, b"GET / HTTP/1.0\r\n\r\n")
    assert status == 200 and headers["Content-Type"] == "text/html; charset=utf-8"
    assert b"<h1>Library " in body and "frame-ancestors 'none'" in headers["Content-Security-Policy"]
    status, headers, body = _raw(server, b"HEAD /assets/plotly.min.js HTTP/1.0\r\n\r\n")
    assert status == 200 and body == b"" and int(headers["Content-Length"]) > 1_000_000


@pytest.mark.parametrize("path", ["/../../../../etc/passwd", "/%2e%2e/%2e%2e/etc/passwd",
                                  "/assets/../index.html", "//etc/passwd", "/assets/", "/assets",
                                  "/etc/passwd", "/index.html/..",
                                  "/skill-0.html%00.js", "/%2fetc%2fpasswd", "/lib.db", "/.skillbank-view"])
def test_the_server_answers_nothing_outside_its_pages(server, path):
    status, _, body = _raw(server, f"GET {path} HTTP/1.0\r\n\r\n".encode())
    assert status == 404 and body == b"not found\n"


@pytest.mark.parametrize("method", ["POST", "PUT", "DELETE", "PATCH", "OPTIONS", "TRACE", "PROPFIND"])
def test_the_server_refuses_every_other_method(server, method):
    request = f"{method} /index.html HTTP/1.0\r\nContent-Length: 2\r\n\r\nhi"
    status, headers, body = _raw(server, request.encode())
    assert status == 405 and headers["Allow"] == "GET, HEAD" and b"read-only" in body


def test_the_log_shows_a_hostile_request_line_escaped(server):
    _raw(server, b"GET /\x1b[2J HTTP/1.0\r\n\r\n")
    logged = server.log_text.getvalue()
    assert "\x1b" not in logged and "\\x1b[2J" in logged


def test_the_served_view_is_live(tmp_path):
    path = tmp_path / "lib.db"
    t = np.linspace(0.0, 1.0, 30)
    with open_store(path) as store:
        store.add_demonstration(Demonstration.from_array(np.c_[t, t, t], t), [(0, 30)])
        with ViewServer(lambda: open_store(path, readonly=True), log=None) as server:
            server.start()
            conn = http.client.HTTPConnection("127.0.0.1", server.port, timeout=10)
            conn.request("GET", "/")
            assert b"1 demonstration(s), 1 primitive(s)" in conn.getresponse().read()
            store.add_demonstration(Demonstration.from_array(np.c_[t, t, t], t), [(0, 10), (10, 30)])
            conn.request("GET", "/demonstration-2.html")
            assert conn.getresponse().status == 200
            conn.close()


def test_parse_address_refuses_what_is_no_port():
    assert parse_address("127.0.0.1:0") == ("127.0.0.1", 0)
    for bad in ("", "x", ":80", "1.2.3.4:", "70000", "host:-1"):
        with pytest.raises(ValueError, match=r"serve: expected \[HOST:\]PORT"):
            parse_address(bad)


# -- PostgreSQL: the password reaches no page, log or error -------------------------------------------------
def test_a_postgresql_library_is_viewed_and_served_without_its_password(postgres_url, tmp_path, cli):
    password = secrets(postgres_url)[0]
    assert password and password in postgres_url
    t = np.linspace(0.0, 1.0, 40)
    with Library(postgres_url) as lib:
        lib.add_many([Demonstration.from_array(np.c_[t, t ** k, t], t) for k in (1, 2, 3)], segment=False)
        lib.cluster()
        lib.label("line", cluster=0)
    code, out, err = cli("library", "view", postgres_url, "--out", tmp_path / "site")
    assert code == 0 and password not in out + err and "***" in out
    for page in (tmp_path / "site").glob("*.html"):
        assert password not in page.read_text()
    log = io.StringIO()
    with ViewServer(lambda: Library(postgres_url, readonly=True), log=log) as server:
        server.start()
        _, _, body = _raw(server, f"GET /?password={password} HTTP/1.0\r\n\r\n".encode())
        assert b"Library postgresql://" in body and password.encode() not in body
    assert password not in log.getvalue() and "password=***" in log.getvalue()
    wrong = postgres_url.replace(password, password + "x")
    code, out, err = cli("library", "view", wrong, "--out", tmp_path / "other")
    assert code == 2 and err.startswith("skillbank library view: error: ") and password not in err
    assert not (tmp_path / "other").exists()


# -- the command line --------------------------------------------------------------------------------------
def test_the_command_writes_the_site_and_says_where(cli, view_library, tmp_path):
    code, out, err = cli("library", "view", view_library["path"], "--out", tmp_path / "site")
    assert (code, err) == (0, "")
    assert out.splitlines()[-1] == f"  open {tmp_path / 'site' / 'index.html'}"
    code, out, err = cli("library", "view", view_library["path"], "--out", tmp_path / "site")
    assert code == 2 and "out: " in err and "give --force to overwrite it" in err  # a view is there
    code, out, _ = cli("library", "view", view_library["path"], "--out", tmp_path / "site", "--json",
                       "--page-size", "2", "--force")
    doc = json.loads(out)
    assert code == 0 and doc["index"] == str(tmp_path / "site" / "index.html")
    assert (tmp_path / "site" / f"skill-{view_library['straight']}-3.html").is_file()


@pytest.mark.parametrize(("argv", "message"), [
    (["--out", "{tmp}/full"], "out: '{tmp}/full' exists; give --force to overwrite it"),
    # --force replaces a view, never a folder of something else
    (["--out", "{tmp}/full", "--force"], "out: folder '{tmp}/full' is not empty and holds no skillbank view"),
    (["--out", "{tmp}/site", "--page-size", "0"], "page-size: expected a positive integer, got 0"),
    (["--serve", "localhost:port"], "serve: expected [HOST:]PORT with PORT an integer in 0..65535"),
])
def test_the_command_refuses_in_one_line(cli, view_library, tmp_path, argv, message):
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "x").write_text("x")
    argv = [a.format(tmp=tmp_path) for a in argv]
    code, out, err = cli("library", "view", view_library["path"], *argv)
    assert code == 2 and out == "" and err.count("\n") == 1
    assert err.startswith(f"skillbank library view: error: {message.format(tmp=tmp_path)}"), err
    assert not (tmp_path / "site").exists()


def test_the_command_needs_out_or_serve(cli, view_library):
    with pytest.raises(SystemExit) as info:
        cli("library", "view", view_library["path"])
    assert info.value.code == 2


def test_without_plotly_the_command_names_the_extra(cli, view_library, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "plotly", None)  # as if the extra were not installed
    code, out, err = cli("library", "view", view_library["path"], "--out", tmp_path / "site")
    assert code == 2 and "pip install 'skillbank[view]'" in err and not (tmp_path / "site").exists()


def test_a_missing_library_is_one_line(cli, tmp_path):
    code, _, err = cli("library", "view", tmp_path / "none.db", "--out", tmp_path / "site")
    assert code == 2 and err.startswith("skillbank library view: error: library ") and err.count("\n") == 1


def test_the_command_serves_until_interrupted(view_library):
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    argv = ["library", "view", str(view_library["path"]), "--serve", "0", "--json"]  # the host: 127.0.0.1
    # started with SIGINT ignored (by a pytest-xdist worker, a shell's background job): Ctrl-C still stops it
    proc = subprocess.Popen([sys.executable, "-m", "skillbank.cli", *argv], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env, stdin=subprocess.DEVNULL,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    try:
        doc = json.loads(proc.stdout.readline())
        assert doc["url"].startswith("http://127.0.0.1:")
        host, port = doc["url"][len("http://"):].rstrip("/").split(":")
        conn = http.client.HTTPConnection(host, int(port), timeout=10)
        conn.request("GET", "/planning.html")
        assert conn.getresponse().read().count(b"<h2>") == 1
        conn.request("DELETE", "/index.html")
        assert conn.getresponse().status == 405
        conn.close()
    finally:
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=20)
    assert proc.returncode == 0 and "stopped" in err
    assert '"DELETE /index.html HTTP/1.1" 405' in err


def test_a_port_in_use_is_one_line(cli, view_library):
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        code, out, err = cli("library", "view", view_library["path"], "--serve", f"127.0.0.1:{port}")
    assert code == 2 and out == "" and err.count("\n") == 1
    assert err.startswith(f"skillbank library view: error: serve: cannot listen on 127.0.0.1:{port}: ")


def test_an_ipv6_host_is_served(view_library):
    try:
        socket.socket(socket.AF_INET6).close()
        with socket.socket(socket.AF_INET6) as probe:
            probe.bind(("::1", 0))
    except OSError as exc:
        pytest.skip(f"no IPv6 loopback here: {exc}")
    with ViewServer(lambda: Library(view_library["path"], readonly=True), host="::1", log=None) as server:
        server.start()
        assert server.url.startswith("http://[::1]:")
        conn = http.client.HTTPConnection("::1", server.port, timeout=10)
        conn.request("HEAD", "/")
        assert conn.getresponse().status == 200
        conn.close()


def test_a_page_that_fails_is_a_500_logged_without_its_password(view_library, monkeypatch):
    def broken(self, name):
        raise ValueError("library 'postgresql://ann:s3cret@db.lab/skills': connection lost")

    monkeypatch.setattr(LibraryView, "render", broken)
    log = io.StringIO()
    with ViewServer(lambda: Library(view_library["path"], readonly=True), log=log) as server:
        server.start()
        status, _, body = _raw(server, b"GET /index.html HTTP/1.0\r\n\r\n")
        assert (status, body) == (500, b"the page could not be rendered\n")
        assert _raw(server, b"GET /assets/view.css HTTP/1.0\r\n\r\n")[0] == 200  # still serving
    logged = log.getvalue()
    assert "s3cret" not in logged and "postgresql://ann:***@db.lab/skills" in logged
    assert "error rendering /index.html: library" in logged


def test_an_empty_library_has_a_view(cli, tmp_path):
    assert cli("library", "init", tmp_path / "empty.db")[0] == 0
    code, out, _ = cli("library", "view", tmp_path / "empty.db", "--out", tmp_path / "site", "--json")
    assert code == 0 and json.loads(out)["pages"] == 4
    index = (tmp_path / "site" / "index.html").read_text()
    assert "0 demonstration(s), 0 primitive(s); no clustering yet" in index
    assert "No skill has a description" in (tmp_path / "site" / "planning.html").read_text()


def test_a_skill_page_says_where_each_members_label_comes_from(view_library):
    with Library(view_library["path"], readonly=True) as lib:
        view = LibraryView(lib)
        bowed = view.render(f"skill-{view_library['bowed']}.html")
        straight = view.render(f"skill-{view_library['straight']}.html")
    arc = '<span class="label {0}">arc</span> <span class="note">({0})</span>'
    assert bowed.count(arc.format("given")) == 1 and bowed.count(arc.format("inferred")) == 5
    assert "<h1>cluster" in bowed and "(inferred, from its labelled members)</span></h1>" in bowed
    own = '<span class="label given">own-label</span> <span class="note">(given)</span>'
    assert straight.count(own) == 1 and straight.count('<span class="note">(cluster)</span>') == 5
