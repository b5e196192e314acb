"""The PostgreSQL store beyond the shared contract: URLs and passwords, opening, schema, concurrency.

Run against the real server of ``conftest.py`` (each test a fresh database); the contract every
backend meets is ``test_store_contract.py``.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
import time
from urllib.parse import quote

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from skillbank import Demonstration
from skillbank.store import SCHEMA_VERSION, STORES, PostgresStore, SQLiteStore, mask_url, open_store
from skillbank.store._postgres_schema import STEPS, create_tables, scrub
from skillbank.store._registry import backend


def _demo(n=30, seed=0):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.01, 0.02, n))
    return Demonstration(t, {"position": rng.normal(size=(n, 3))}, {"seed": seed})


# -- URLs and passwords (no server) ------------------------------------------------------------------
@pytest.mark.parametrize("url, shown", [
    ("postgresql://ann:s3cret@db.lab:5432/skills", "postgresql://ann:***@db.lab:5432/skills"),
    ("postgres://ann:p%40ss@h1:5432,h2:5433/skills?sslmode=require",
     "postgres://ann:***@h1:5432,h2:5433/skills?sslmode=require"),
    ("postgresql://ann:a/b@c@db/skills", "postgresql://ann:***@db/skills"),  # '/' and '@' unencoded
    ("postgresql:///skills?host=/run/pg&password=s3cret&sslmode=disable",
     "postgresql:///skills?host=/run/pg&password=***&sslmode=disable"),
    ("postgresql://ann@db/skills", "postgresql://ann@db/skills"),
    ("skills.db", "skills.db"),
])
def test_mask_url_hides_every_password(url, shown):
    assert mask_url(url) == shown


# no whitespace: the message below separates its two quotations with a newline, which a password
# of whitespace would itself be (the scrub then cannot tell the separator from the secret)
@given(st.text(min_size=1, max_size=30).filter(lambda p: not set(p) & set('*"') and not any(
    c.isspace() for c in p)))
def test_no_password_survives_masking_or_scrubbing(password):
    encoded = quote(password, safe="")  # as a URL must hold it
    user_part = f"postgresql://ann:{encoded}@db.lab:5432/skills?sslmode=require"
    parameter = f"postgresql://ann@db.lab/skills?password={encoded}&sslmode=require"
    assert mask_url(user_part) == "postgresql://ann:***@db.lab:5432/skills?sslmode=require"
    assert mask_url(parameter) == "postgresql://ann@db.lab/skills?password=***&sslmode=require"
    for url in (user_part, parameter):  # a driver's message quoting the password, written or decoded
        assert scrub(f'"{encoded}"\n"{password}"', url) == '"***" "***"'


def test_postgres_urls_have_a_backend_and_psycopg_is_optional(monkeypatch):
    assert STORES["postgresql"] is PostgresStore and backend("postgres") is PostgresStore
    assert backend("POSTGRESQL") is PostgresStore
    with pytest.raises(ValueError, match=r"no store backend for mysql:// \(known: postgres, postgresql, "
                                         r"sqlite; a plain path is a SQLite file\)"):
        open_store("mysql://db/skills")
    with pytest.raises(ValueError, match=r"^timeout: expected a number > 0, got str 'soon'$"):
        PostgresStore("postgresql://ann@127.0.0.1:1/skills", timeout="soon")
    monkeypatch.setitem(sys.modules, "psycopg", None)  # as if it were not installed
    with pytest.raises(ImportError, match=r"^PostgreSQL libraries need psycopg 3: "
                                          r"pip install 'skillbank\[postgres\]'$"):
        open_store("postgresql://ann:s3cret@127.0.0.1:1/skills")


# -- opening -------------------------------------------------------------------------------------------
def test_connection_failures_are_one_line_with_the_password_masked(postgres_server, postgres_url):
    port = postgres_server.port
    wrong = postgres_server.url("postgres", password="n0t-the-Pa55word")
    for url, match in [
        (wrong, r"password authentication failed for user \"skillbank\" \(the password comes from the URL, "
                r"PGPASSWORD or ~/.pgpass\)"),
        (f"postgresql://skillbank:se%zzcret@127.0.0.1:{port}/x",
         r"a '%' in the user part is not followed by two hex digits; percent-encode the password"),
        (f"postgresql://skillbank:s3cret@127.0.0.1:{port}/x?colour=red", r"invalid URI query parameter"),
        (f"postgresql://skillbank:s3cret@127.0.0.1:{port}x/x", r"invalid integer value .* \"port\""),
        ("postgresql://skillbank:s3cret@127.0.0.1:1/x", r"Connection refused"),
        (postgres_server.url("nowhere"), r"database \"nowhere\" does not exist \(create it with 'createdb'"),
    ]:
        with pytest.raises(ValueError, match=r"^library 'postgresql://skillbank:\*\*\*@127\.0\.0\.1:") as err:
            open_store(url)
        message = str(err.value)
        assert "\n" not in message and len(message) < 400, message
        for secret in ("n0t-the-Pa55word", "s3cret", "se%zzcret", postgres_server.password):
            assert secret not in message
        assert re.search(match, message), message


def test_passwords_from_pgpassword_and_pgpass(postgres_server, postgres_url, tmp_path, monkeypatch):
    bare = postgres_server.url(postgres_url.rsplit("/", 1)[1], password="")
    monkeypatch.setenv("PGPASSFILE", str(tmp_path / "none"))
    monkeypatch.delenv("PGPASSWORD", raising=False)
    with pytest.raises(ValueError, match=r"(no password supplied|password authentication failed).* "
                                         r"\(the password comes from the URL, PGPASSWORD or ~/\.pgpass\)"):
        open_store(bare)
    monkeypatch.setenv("PGPASSWORD", postgres_server.password)
    with open_store(bare) as store:
        assert store.location == bare and store.demonstration_ids() == []
    monkeypatch.delenv("PGPASSWORD")
    pgpass = tmp_path / "pgpass"
    pgpass.write_text(f"127.0.0.1:{postgres_server.port}:*:skillbank:{postgres_server.password}\n")
    pgpass.chmod(0o600)  # libpq ignores a password file others can read
    monkeypatch.setenv("PGPASSFILE", str(pgpass))
    with open_store(bare.replace("postgresql://", "postgres://")) as store:
        assert isinstance(store, PostgresStore) and store.current_version() is None


def test_unix_socket_and_schemas_hold_separate_libraries(postgres_server, postgres_url):
    dbname = postgres_url.rsplit("/", 1)[1]
    with postgres_server.admin(dbname) as conn:
        conn.execute("CREATE SCHEMA lab_a")
        conn.execute("CREATE SCHEMA lab_b")
    socket = postgres_server.socket_url(dbname)  # ?host=/folder&port=...
    with open_store(socket + "&options=-csearch_path%3Dlab_a") as a, \
            open_store(postgres_url + "?sslmode=disable&options=-csearch_path%3Dlab_b") as b:
        assert a.created and b.created
        a.add_demonstration(_demo(), [(0, 30)])
        assert len(a.demonstration_ids()) == 1 and b.demonstration_ids() == []
        b.add_demonstration(_demo(seed=1), [(0, 10), (10, 30)])
        assert [p.id for p in b.primitives()] == [1, 2] and [p.id for p in a.primitives()] == [1]
    with postgres_server.admin(dbname) as conn:
        tables = {r[0] for r in conn.execute("SELECT table_schema FROM information_schema.tables "
                                             "WHERE table_name = 'primitives'")}
    assert tables == {"lab_a", "lab_b"}  # nothing in public


def test_create_false_read_only_and_foreign_tables(postgres_server, postgres_url):
    with pytest.raises(ValueError, match=r"^library '.*' does not exist \(schema 'public' holds no "
                                         r"library\); create it with 'skillbank library init'$"):
        open_store(postgres_url, create=False)
    with pytest.raises(ValueError, match=r"does not exist"):
        open_store(postgres_url, readonly=True)
    with pytest.raises(ValueError, match=r"^library '.*': no schema to hold it \(the search_path names none "
                                         r"that exists\)$"):
        open_store(postgres_url + "?options=-csearch_path%3Dnowhere")
    with open_store(postgres_url) as store:
        did, pids = store.add_demonstration(_demo(), [(0, 30)])
    with open_store(postgres_url, readonly=True, create=False) as ro:
        assert ro.readonly and ro.demonstration_ids() == [did]
        for write, what in [
            (lambda: ro.add_demonstration(_demo(), [(0, 30)]), "add demonstrations"),
            (lambda: ro.remove_demonstration(did), "remove a demonstration"),
            (lambda: ro.set_label("x", primitive=pids[0]), "label"),
            (lambda: ro.add_members(1, []), "assign primitives to clusters"),
            (lambda: ro.import_folder("anywhere"), "import"),
        ]:
            with pytest.raises(ValueError, match=rf"^library '.*' is open read-only: cannot {what}$"):
                write()
        import psycopg

        with pytest.raises(psycopg.errors.ReadOnlySqlTransaction):  # the server refuses too
            ro.conn.execute("DELETE FROM demonstrations")
    dbname = postgres_url.rsplit("/", 1)[1]
    with postgres_server.admin(dbname) as conn:
        conn.execute("CREATE SCHEMA other")
        conn.execute("CREATE TABLE other.meta (key TEXT, value TEXT)")
        conn.execute("CREATE TABLE other.orders (id INT)")
        conn.execute("UPDATE meta SET value = '9' WHERE key = 'schema_version'")
    with pytest.raises(ValueError, match=r"schema 'other' holds tables that are not a skillbank library "
                                         r"\(meta, orders\)"):
        open_store(postgres_url + "?options=-csearch_path%3Dother")
    with postgres_server.admin(dbname) as conn:
        assert conn.execute("SELECT COUNT(*) FROM other.meta").fetchone()[0] == 0  # left as it was
    with pytest.raises(ValueError, match=r"has schema version 9, written by a newer skillbank; this one "
                                         rf"reads versions up to {SCHEMA_VERSION}"):
        open_store(postgres_url)


def test_every_schema_version_has_its_postgres_migration():
    assert len(STEPS) == SCHEMA_VERSION  # a new SQLite version needs its PostgreSQL statements too


def test_a_version_1_library_is_migrated_like_sqlite(postgres_server, postgres_url):
    dbname = postgres_url.rsplit("/", 1)[1]
    with postgres_server.admin(dbname) as conn, conn.transaction():
        cur = conn.cursor()
        create_tables(cur, version=1)
        from skillbank.store._arrays import to_npy

        cur.execute("INSERT INTO demonstrations (id, source, n_steps, t, metadata, created) "
                    "VALUES (1, 'old.h5', 3, %s, '{}', 'then')", (to_npy(np.arange(3.0)),))
        cur.execute("INSERT INTO streams VALUES (1, 'position', 0, %s)", (to_npy(np.zeros((3, 2))),))
        cur.execute("INSERT INTO primitives VALUES (1, 1, 0, 3, NULL)")
        cur.execute("UPDATE sequences SET last = 1 WHERE name IN ('demonstrations', 'primitives')")
    with pytest.raises(ValueError, match=rf"has schema version 1; open it once read-write .* version "
                                         rf"{SCHEMA_VERSION}"):
        open_store(postgres_url, readonly=True)
    with open_store(postgres_url) as store:
        assert not store.created
        assert store.provenance(1) == {"unknown": True, "migrated_from_schema": 1}
        did, pids = store.add_demonstration(_demo(), [(0, 30)], provenance={"window": 8})
        assert (did, pids) == (2, [2]) and store.provenance(did) == {"window": 8}
        assert store.check() == "ok" and store.descriptions() == []
    with postgres_server.admin(dbname) as conn:
        assert conn.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()[0] == \
            str(SCHEMA_VERSION)


def test_skill_descriptions_are_revised_as_in_sqlite(postgres_url, tmp_path):
    with open_store(postgres_url) as pg, SQLiteStore(tmp_path / "s.db") as lite:
        for store in (pg, lite):
            assert store.set_description("press", "(:action press)", {"button": [0.1, 0.2]}) == 1
            assert store.set_description("press", "(:action press :parameters (?b))", {}) == 2
            assert store.set_description("reach", "(:action reach)", {}) == 1
            assert store.set_description("reach", None, {}) == 2  # removed
        pg_rows, lite_rows = pg.descriptions(history=True), lite.descriptions(history=True)
        assert [{k: v for k, v in d.items() if k != "created"} for d in pg_rows] == \
            [{k: v for k, v in d.items() if k != "created"} for d in lite_rows]
        assert [(d["label"], d["revision"]) for d in pg.descriptions()] == [("press", 2)]
        with pytest.raises(ValueError, match=r"^action: expected PDDL text \(a string\) or None, got int$"):
            pg.set_description("press", 3, {})


def test_a_failed_write_uses_no_id_and_check_finds_a_broken_counter(postgres_server, postgres_url):
    with open_store(postgres_url) as store:
        store.add_demonstration(_demo(), [(0, 30)])
        bad = _demo(seed=1)
        bad.metadata["handle"] = object()
        with pytest.raises(TypeError):
            store.add_demonstration(bad, [(0, 30)])
        assert store.add_demonstration(_demo(seed=2), [(0, 15), (15, 30)]) == (2, [2, 3])  # as SQLite
        store.remove_demonstration(2)
        assert store.add_demonstration(_demo(seed=3), [(0, 30)]) == (3, [4])  # ids are never reused
        assert store.check() == "ok"
        with postgres_server.admin(postgres_url.rsplit("/", 1)[1]) as conn:
            conn.execute("UPDATE sequences SET last = 1 WHERE name = 'primitives'")
            conn.execute("UPDATE primitives SET stop = 99 WHERE id = 1")
        assert store.check() == ("counter of primitives at 1, below its largest id 4; "
                                 "1 primitive(s) outside their demonstration")


def test_a_writer_waits_for_the_lock_then_gives_up_in_one_line(postgres_server, postgres_url):
    with open_store(postgres_url) as holder, open_store(postgres_url, timeout=0.3) as waiter:
        with holder._write("hold") as cur:  # another writer's transaction, still open
            cur.execute("SELECT 1")
            start = time.perf_counter()
            with pytest.raises(ValueError, match=r"^library '.*': another writer held it longer than the "
                                                 r"timeout \(0\.3 s\); nothing was written$"):
                waiter.add_demonstration(_demo(), [(0, 30)])
            assert time.perf_counter() - start >= 0.25
            assert waiter.demonstration_ids() == []  # readers never wait
        assert waiter.add_demonstration(_demo(), [(0, 30)]) == (1, [1])


_WRITER = textwrap.dedent("""
    import sys, time
    import numpy as np
    from skillbank import Demonstration
    from skillbank.store import open_store

    url, k, start = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
    while time.time() < start:  # every process opens (and creates the library) at once
        time.sleep(0.001)
    with open_store(url) as store:
        pids = []
        for batch in range(5):
            items = []
            for j in range(2):
                seed = 1000 * k + 10 * batch + j
                rng = np.random.default_rng(seed)
                t = np.cumsum(rng.uniform(0.01, 0.02, 40))
                demo = Demonstration(t, {"position": rng.normal(size=(40, 3))}, {"seed": seed})
                items.append({"demo": demo, "bounds": [(0, 10), (10, 25), (25, 40)], "source": f"w{k}"})
            pids += [p for _, ps in store.add_demonstrations(items) for p in ps]
        version = store.add_version(params={"writer": k}, centers=np.zeros((1, 2)), pca_mean=np.zeros(2),
                                    pca_components=np.eye(2), members=[(p, 0, np.zeros(2)) for p in pids])
        store.set_label(f"p{k}", primitive=pids[0])
        print(version)
""")


def test_eight_processes_write_one_library_at_once(postgres_url):
    start = time.time() + 2.0
    env = {**os.environ, "PYTHONWARNINGS": "error::RuntimeWarning"}
    procs = [subprocess.Popen([sys.executable, "-c", _WRITER, postgres_url, str(k), str(start)],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
             for k in range(8)]
    results = [p.communicate(timeout=120) for p in procs]
    assert [p.returncode for p in procs] == [0] * 8, [err for _, err in results]
    with open_store(postgres_url, readonly=True) as store:
        assert store.demonstration_ids() == list(range(1, 81))  # every row, no gap, no duplicate
        prims = store.primitives(load=False)
        assert [p.id for p in prims] == list(range(1, 241))
        assert sorted(int(out) for out, _ in results) == list(range(1, 9)) == \
            [v["version"] for v in store.versions()]
        for v in store.versions():  # each writer's version holds exactly its own 30 primitives
            mine = {p.id for p in store.primitives(load=False, source=f"w{v['params']['writer']}")}
            assert len(mine) == 30 and set(store.members(v["version"])) == mine
        for did, demo in store.demonstrations(store.demonstration_ids()).items():
            seed = demo.metadata["seed"]
            rng = np.random.default_rng(seed)
            t = np.cumsum(rng.uniform(0.01, 0.02, 40))
            np.testing.assert_array_equal(demo.t, t)
            np.testing.assert_array_equal(demo["position"], rng.normal(size=(40, 3)))
            assert [(p.start, p.stop) for p in store.primitives(demonstration=did, load=False)] == \
                [(0, 10), (10, 25), (25, 40)]
        assert sorted(p.label for p in prims if p.label_source == "given") == [f"p{k}" for k in range(8)]
        assert store.check() == "ok"


def test_a_role_that_may_only_read_can_list_but_not_write(cli, postgres_server, postgres_url):
    dbname = postgres_url.rsplit("/", 1)[1]
    with open_store(postgres_url) as store:
        store.add_demonstration(_demo(), [(0, 30)], label="reach")
    role = f"reader_{dbname}"
    with postgres_server.admin(dbname) as conn:
        conn.execute(f"CREATE ROLE {role} LOGIN PASSWORD 'r3ad-only'")
        conn.execute(f"GRANT SELECT ON ALL TABLES IN SCHEMA public TO {role}")
    reader = postgres_url.replace(f"skillbank:{postgres_server.password}@", f"{role}:r3ad-only@")
    try:
        code, out, err = cli("library", "list", reader, "--json")
        assert code == 0, err
        assert [p["label"] for p in json.loads(out)["primitives"]] == ["reach"]
        code, out, err = cli("library", "label", reader, "--primitive", "1", "push")
        assert code == 2 and err.count("\n") == 1 and "r3ad-only" not in err
        assert "InsufficientPrivilege: permission denied for table" in err, err
    finally:
        with postgres_server.admin() as conn:
            conn.execute(f"DROP DATABASE {dbname} WITH (FORCE)")
            conn.execute(f"DROP ROLE {role}")
