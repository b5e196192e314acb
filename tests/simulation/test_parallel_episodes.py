"""Episodes in parallel (issue 42, item 6): ``--workers`` and ``--scheduler`` give the serial report.

Real robosuite episodes of a tiny library (two recorded Lift demonstrations), a short horizon, and real
Dask clusters: a new local one (``--workers 2``) and an existing ``distributed.LocalCluster`` reached by
its address (``--scheduler``), whose workers are made to die on one episode.
"""

from __future__ import annotations

import contextlib
import io
import json
import logging
import os
import sys
import time

import pytest

pytest.importorskip("robosuite")  # the extra skillbank[sim]
distributed = pytest.importorskip("distributed")  # the extra skillbank[dask]

import dask  # noqa: E402

from skillbank.cli import main  # noqa: E402
from skillbank.simulation import evaluate, execute_plan  # noqa: E402

from .conftest import recorded_lift  # noqa: E402

#: A run: two scenes no demonstration had, 200 control steps each at most (a lift takes about 130).
RUN = ["--env", "robosuite:Lift", "--episodes", "2", "--seed", "500", "--placement", "0.12",
       "--horizon", "200", "--json"]


@pytest.fixture(scope="module")
def lift(tmp_path_factory):
    return recorded_lift(tmp_path_factory.mktemp("lift_par"), episodes=2)


def run(*args):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def serial(lift):
    code, out, err = run("sim", "evaluate", lift, *RUN)
    assert code == 0 and err == "", err
    return json.loads(out)


@pytest.fixture(scope="module")
def dask_cluster():
    # a worker that dies once fails its task: the test of a dead worker needs no retries (the episodes
    # send a worker only the task it runs, so the task that killed it is the one blamed)
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        cluster = distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                           dashboard_address=":0", silence_logs=logging.ERROR)
    try:
        yield cluster
    finally:
        cluster.close()


def same_report(a, b):
    """Every field but the timings and the cluster's address: the per-episode rows in full."""
    def drop(doc):
        return {k: v for k, v in doc.items() if k not in ("timing", "scheduler")}

    assert drop(a) == drop(b)
    assert [r["seed"] for r in a["per_episode"]] == [500, 501]


def test_an_episode_is_the_same_alone_as_after_others(lift, serial):
    """Each episode builds its own environment from its seed: nothing carries over from the one before
    (one environment reset per episode left the cube 0.5 mm lower after another episode)."""
    alone = evaluate(lift, "robosuite:Lift", episodes=1, seed=501, placement=0.12, horizon=200)
    assert alone["per_episode"] == serial["per_episode"][1:]
    assert serial["successes"] >= 1  # the runs compared below do something


def _threads(job, seed):
    from threadpoolctl import threadpool_info

    return {"seed": seed, "success": True,
            "threads": [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]}, None


def test_an_episode_here_runs_its_linear_algebra_on_one_thread_as_a_dask_worker_does():
    """Dask's nanny starts a worker with one BLAS thread; a product split over two adds in another order,
    and a contact-rich episode turns the last bits into another outcome: here, too, an episode runs on
    one thread, and the caller's threads are as they were after it."""
    import numpy as np
    from threadpoolctl import threadpool_info, threadpool_limits

    from skillbank.simulation._episodes import run_episodes

    assert np.ones(2) @ np.ones(2) == 2.0  # numpy's BLAS loaded
    with threadpool_limits(limits=2):
        before = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
        rows, where = run_episodes(_threads, None, [1, 2])
        after = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
    assert where is None and [r["seed"] for r, _ in rows] == [1, 2]
    assert all(r["threads"] and set(r["threads"]) == {1} for r, _ in rows)
    assert 2 in before and after == before


def test_two_local_workers_give_the_serial_report(lift, serial):
    code, out, err = run("sim", "evaluate", lift, *RUN, "--workers", "2")
    assert code == 0
    assert err == ""  # robosuite's and Dask's log lines are off, in the workers too
    doc = json.loads(out)  # nothing a worker printed is mixed into the report
    same_report(doc, serial)
    assert doc["scheduler"].startswith("tcp://127.0.0.1:")
    assert doc["timing"]["segments"] == serial["timing"]["segments"]


def test_an_existing_cluster_gives_the_serial_report_and_its_progress(lift, serial, dask_cluster):
    ticks = []
    report = evaluate(lift, "robosuite:Lift", episodes=2, seed=500, placement=0.12, horizon=200,
                      scheduler=dask_cluster.scheduler_address, progress=lambda *a: ticks.append(a))
    same_report(json.loads(json.dumps(report)), serial)
    assert report["scheduler"] == dask_cluster.scheduler_address
    assert [done for done, _ in ticks] == [1, 2] and ticks[-1][1] == serial["successes"]


def _die_on(seed):
    """Make every worker of the cluster (and every restarted one) die on the episode of ``seed``."""

    class Poison(distributed.WorkerPlugin):
        name = "poison"

        def setup(self, worker):
            import skillbank.simulation._evaluate as evaluation

            original = evaluation._evaluate_episode

            def episode(job, s):
                if s == seed:
                    os._exit(1)
                return original(job, s)

            self.original, evaluation._evaluate_episode = original, episode

        def teardown(self, worker):
            import skillbank.simulation._evaluate as evaluation

            evaluation._evaluate_episode = self.original

    return Poison()


def test_a_worker_that_dies_is_one_line_and_no_report(lift, dask_cluster):
    with distributed.Client(dask_cluster, set_as_default=False) as client:
        client.register_plugin(_die_on(500))
        try:
            code, out, err = run("sim", "evaluate", lift, *RUN, "--scheduler", dask_cluster.scheduler_address)
        finally:
            client.unregister_worker_plugin("poison")
            client.wait_for_workers(1, timeout=60)
    assert code == 2 and out == ""  # never a report of the episodes that did run
    assert err == ("skillbank sim evaluate: error: episode of seed 500: the Dask worker running it died, and "
                   "again on every retry (a crash, or more memory than a worker has)\n")


COMMANDS = {
    "sim evaluate": ["sim", "evaluate", "{db}", "--env", "robosuite:Lift"],
    "plan": ["plan", "{db}", "--scene", "robosuite:Stack3", "--simulate"],
    "experiment stack3": ["experiment", "stack3", "--episodes", "2"],
}


@pytest.mark.parametrize("command", sorted(COMMANDS))
@pytest.mark.parametrize("options, message", [
    (["--workers", "0", "--scheduler", "tcp://h:1"],
     "workers: --workers 0 works in this process, --scheduler on a cluster: give one, got --workers 0 and "
     "--scheduler 'tcp://h:1'"),
    (["--workers", "2", "--scheduler", "tcp://h:1"],
     "workers: give workers (a new local cluster) or scheduler (an existing one), not both; got "
     "workers=2 and scheduler='tcp://h:1'"),
    (["--workers", "1000000000000000000"], "workers: at most "),
    (["--scheduler", "http://127.0.0.1:8787"], "scheduler: http://127.0.0.1:8787 is a web address"),
    (["--scheduler", "tcp://nowhere"], "scheduler: expected tcp://HOST:PORT with a port from 1 to 65535"),
])
def test_bad_parallel_options_are_one_line_before_any_work(lift, command, options, message):
    argv = [a.replace("{db}", str(lift)) for a in COMMANDS[command]]
    start = time.monotonic()
    code, out, err = run(*argv, *options)
    assert code == 2 and out == ""
    assert err.startswith(f"skillbank {command}: error: {message}") and err.count("\n") == 1, err
    assert time.monotonic() - start < 10  # nothing recorded, no episode, no cluster (about a second)


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_a_negative_worker_count_is_a_usage_error(lift, command, capsys):
    argv = [a.replace("{db}", str(lift)) for a in COMMANDS[command]]
    with pytest.raises(SystemExit, match="2"):
        main([*argv, "--workers", "-1"])
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "argument --workers: expected an integer >= 0, got '-1'" in err


def test_a_plan_of_a_scene_file_has_no_episodes_to_share(lift, tmp_path):
    scene = tmp_path / "scene.json"
    scene.write_text("{}")
    code, out, err = run("plan", lift, "--scene", scene, "--workers", "2")
    assert code == 2 and out == ""
    assert err == ("skillbank plan: error: --workers: runs the episodes of a robosuite scene (--scene "
                   "robosuite:TASK --simulate) in parallel; leave it out\n")


def test_bad_arguments_are_value_errors(lift):
    with pytest.raises(ValueError, match=r"^workers: expected an integer > 0, got 0$"):
        evaluate(lift, "robosuite:Lift", workers=0)
    with pytest.raises(ValueError, match=r"^workers: give workers \(a new local cluster\) or scheduler"):
        execute_plan(lift, "robosuite:Stack3", workers=1, scheduler="tcp://h:1")
    with pytest.raises(ValueError, match=r"^scheduler: unknown transport ftp://"):
        evaluate(lift, "robosuite:Lift", scheduler="ftp://h:1")


def test_an_unreachable_scheduler_is_one_line(lift, monkeypatch):
    monkeypatch.setenv("SKILLBANK_SCHEDULER", "tcp://127.0.0.1:9")  # discard port: nothing listens
    code, out, err = run("sim", "evaluate", lift, *RUN)
    assert code == 2 and out == "" and err.count("\n") == 1
    assert "error: scheduler: cannot reach the Dask scheduler at 'tcp://127.0.0.1:9'" in err


def test_an_experiment_reaches_its_scheduler_before_it_records(capsys):
    start = time.monotonic()
    code, out, err = run("experiment", "unload", "--scheduler", "tcp://127.0.0.1:9")
    assert code == 2 and out == "" and err.count("\n") == 1
    assert err.startswith("skillbank experiment unload: error: scheduler: cannot reach the Dask scheduler at "
                          "'tcp://127.0.0.1:9'"), err
    assert time.monotonic() - start < 10  # no recording (tens of seconds a task) was made first


def test_missing_dask_is_one_line(lift, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # as if Dask were not installed
    code, out, err = run("sim", "evaluate", lift, *RUN, "--workers", "2")
    assert code == 2 and out == ""
    assert err == ("skillbank sim evaluate: error: parallel episodes (workers, scheduler) need Dask: "
                   "pip install 'skillbank[dask]'\n")
