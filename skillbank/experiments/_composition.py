"""The paper's future work, end to end in physics: ``skillbank experiment unload`` and ``experiment stack3``.

As a user would: record demonstrations of one object at a time (``sim
record``), build a library from them (segment, cluster), label one primitive
per skill (the first that reaches for an object ``pick``, the first that
carries one ``place``: what a person reading ``library list`` would pick),
describe the two skills in PDDL, and ask for a task no demonstration showed,
planned and carried out in a fresh robosuite scene per episode
(:func:`skillbank.simulation.execute_plan`):

- ``unload``: robosuite's ``PickPlace``, the dishwasher's analogue: milk,
  bread, cereal and can, each shown alone (``PickPlaceMilk`` ...), all four
  moved from one bin to their places in the other, in an order the planner
  chooses;
- ``stack3``: three cubes stacked in an order drawn per episode, from
  demonstrations of robosuite's ``Stack`` (one cube on another).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from ..core._cluster_address import probe_scheduler
from ..core._validation import check_positive
from ..pipeline import Library
from ..selection import METHODS
from ..simulation import BASELINES, binomial_interval, execute_plan, record
from ..simulation._compose import tally
from ..simulation._episodes import check_episode_cluster
from ..simulation._evaluate import DRIVEN_ROBOT
from ..simulation._robosuite import robosuite_robot
from ..simulation._stack3 import CUBES
from ..simulation._transit import check_planner

__all__ = ["composition_experiment", "check_options", "COMPOSITIONS", "PICK", "PLACE"]

#: The two skills' PDDL descriptions: a pick needs a free hand and a clear object resting on nothing, a
#: place puts what is held on a clear object or place.
PICK = ("(:action pick :parameters (?o - object) :precondition (and (handempty) (clear ?o) (loose ?o)) "
        ":effect (and (holding ?o) (not (handempty)) (not (loose ?o))))")
PLACE = ("(:action place :parameters (?o - object ?t - object) :precondition (and (holding ?o) (clear ?t)) "
         ":effect (and (on ?o ?t) (handempty) (not (holding ?o)) (not (clear ?t))))")
#: experiment -> (the robosuite tasks demonstrated, the scene the plans run in)
COMPOSITIONS = {
    "unload": (("PickPlaceMilk", "PickPlaceBread", "PickPlaceCereal", "PickPlaceCan"), "robosuite:PickPlace"),
    "stack3": (("Stack",), "robosuite:Stack3"),
}
EPISODE_SEEDS = 1000  # episode k is placed from seed + EPISODE_SEEDS + k: never a recording's seed
#: Seeds reach robosuite's and NumPy's generators, which take 0 to 2^32 - 1.
LAST_SEED = 2 ** 32 - 1


def check_options(name: str, *, episodes, seed, demos, method, replan=False, robot=DRIVEN_ROBOT,
                  record_robot=DRIVEN_ROBOT, workers=None, scheduler=None, planner="ompl") -> dict:
    """Every option of a composition experiment checked, before anything is recorded; the checked values.

    Each is a one-line ValueError naming its own option (``demos``, not ``episodes``), so that a bad
    option costs no recording (tens of seconds per task).

    Examples
    --------
    >>> check_options("stack3", episodes=0, seed=0, demos=1, method="lte")
    Traceback (most recent call last):
    ...
    ValueError: episodes: expected an integer > 0, got 0
    """
    if name not in COMPOSITIONS:
        raise ValueError(f"experiment: expected one of {sorted(COMPOSITIONS)}, got {name!r}")
    episodes = check_positive(episodes, name="episodes", integer=True)
    demos = check_positive(demos, name="demos", integer=True)
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or seed < 0:
        raise ValueError(f"seed: expected a non-negative integer, got {seed!r}")
    last = int(seed) + EPISODE_SEEDS + episodes - 1
    if last > LAST_SEED:
        raise ValueError(f"seed: episode {episodes - 1} would be placed from seed {last} (seed + "
                         f"{EPISODE_SEEDS} + episode), past the generators' last seed {LAST_SEED}; give a "
                         "smaller --seed")
    if method not in METHODS and method not in BASELINES:
        raise ValueError(f"method: expected one of {sorted(METHODS) + list(BASELINES)}, got {method!r}")
    if not isinstance(replan, bool):
        raise ValueError(f"replan: expected True or False, got {replan!r}")
    robot = robosuite_robot(robot)
    planner = check_planner(planner)
    try:
        record_robot = robosuite_robot(record_robot)
    except ValueError as e:  # the same rule, named by its own option
        raise ValueError(str(e).replace("robot:", "record_robot:", 1)) from None
    workers = check_episode_cluster(workers, scheduler)
    if isinstance(scheduler, str):
        probe_scheduler(scheduler)  # a cluster out of reach is found before the recordings, not after
    return {"episodes": episodes, "seed": int(seed), "demos": demos, "method": method, "replan": replan,
            "robot": robot, "record_robot": record_robot, "workers": workers, "scheduler": scheduler,
            "planner": planner}


def _label_one_each(lib) -> dict:
    """Label the first primitive that reaches for an object ``pick`` and the first that carries one
    ``place`` (by id, the order ``library list`` shows); the clusters carry the labels."""
    prims = lib.summary()["primitives"]
    reach = next((p for p in prims if p["acts_on"] and not p["acts_on"]["moves_with"]), None)
    carry = next((p for p in prims if p["acts_on"] and p["acts_on"]["moves_with"]), None)
    if reach is None or carry is None:
        raise ValueError("library: no primitive reaches for an object, or none carries one; the "
                         "demonstrations show no pick and place")
    lib.label("pick", primitive=reach["id"])
    lib.label("place", primitive=carry["id"])
    lib.describe("pick", PICK, {})
    lib.describe("place", PLACE, {})
    return {"pick": reach["id"], "place": carry["id"]}


def _goal(rng) -> list:
    order = [CUBES[i] for i in rng.permutation(len(CUBES))]
    return [f"(on {upper} {lower})" for upper, lower in zip(order[:-1], order[1:], strict=True)]


def _tower_goal(seed) -> list:
    """The tower an episode of ``stack3`` asks for, drawn from the episode's seed (on any worker alike)."""
    return _goal(np.random.default_rng(seed))


def composition_experiment(name: str, *, episodes: int = 10, seed: int = 0, demos: int = 10,
                           method: str = "lte", replan: bool = False, folder=None, paths: bool = False,
                           progress=None, robot: str = DRIVEN_ROBOT, record_robot: str = DRIVEN_ROBOT,
                           workers=None, scheduler=None, verbose: bool = False,
                           planner: str = "ompl") -> dict:
    """Record, build, label, describe, plan and execute: the whole loop of a composed task.

    Parameters
    ----------
    name : {"unload", "stack3"}
        The experiment (:data:`COMPOSITIONS`).
    episodes : int, default=10
        Scenes; episode ``k`` is placed from seed ``seed + 1000 + k`` (the demonstrations from ``seed``).
    demos : int, default=10
        Demonstrations recorded per demonstrated task.
    method : str, default="lte"
        As :func:`~skillbank.simulation.execute_plan`: ``replay`` is the baseline (each phase's recorded
        actions in the planned order, no adaptation).
    planner : {"ompl", "none"}, default="ompl"
        As :func:`~skillbank.simulation.execute_plan`: ``"ompl"`` plans the free-space moves for the whole
        arm where the adapted tool paths would bring it near the scene.
    replan : bool, default=False
        Plan again from the observed facts when a step's effect did not happen.
    folder : path-like, optional
        Where the recordings (``TASK.hdf5``) and the library (``NAME.db``) are written and kept (default: a
        temporary folder, removed); it must not hold them already.
    paths : bool, default=False
        Keep each episode's tool path (for :func:`skillbank.plotting.plot_composed`).
    progress : callable, optional
        ``progress(stage, done, total, successes)``: stage ``"record"`` as it starts and after each
        demonstration kept (``successes`` None), ``"episodes"`` as they start and after each episode
        (``successes`` so far).
    robot : str, default="UR5e"
        robosuite's arm that carries the plans out (any of its single arms, any case: ``panda``), as
        :func:`~skillbank.simulation.execute_plan`'s.
    record_robot : str, default="UR5e"
        robosuite's arm the demonstrations are recorded on (:func:`~skillbank.simulation.record`'s).
        When it is not ``robot``, the skills run on another arm than showed them, through the grip
        site's pose (a note says so).
    workers, scheduler, verbose
        The episodes on Dask (:func:`~skillbank.simulation.execute_plan`): a new local cluster of
        ``workers`` processes or an existing one; the rows are those of a run in this process, in seed
        order. Checked (and the scheduler reached) before anything is recorded.

    Returns
    -------
    dict
        ``{"experiment", "scene", "robot", "recorded_on", "notes", "method", "seed", "demos", "episodes",
        "successes", "success_rate", "interval", "failures", "per_episode", "labelled", "library"}``;
        ``robot`` is the arm that ran the plans, ``recorded_on`` the arms the library's demonstrations
        say they were recorded on, ``notes`` what :func:`~skillbank.simulation.execute_plan` says of
        them (another arm, the poses taken as its grip site's).

    Raises
    ------
    ValueError
        A bad option (:func:`check_options`), before anything is recorded.

    Examples
    --------
    >>> composition_experiment("dishes")
    Traceback (most recent call last):
    ...
    ValueError: experiment: expected one of ['stack3', 'unload'], got 'dishes'
    """
    checked = check_options(name, episodes=episodes, seed=seed, demos=demos, method=method, replan=replan,
                            robot=robot, record_robot=record_robot, workers=workers, scheduler=scheduler,
                            planner=planner)
    episodes, seed, demos = checked["episodes"], checked["seed"], checked["demos"]
    robot, record_robot = checked["robot"], checked["record_robot"]
    tasks, scene = COMPOSITIONS[name]
    with tempfile.TemporaryDirectory() as tmp:
        where = Path(tmp if folder is None else folder)
        files = []
        if progress is not None:  # each stage announced as it starts: a bar that times it from there
            progress("record", 0, demos * len(tasks), None)
        for i, task in enumerate(tasks):
            out = where / f"{task}.hdf5"
            tick = None if progress is None else (lambda kept, _, before=i * demos:
                                                  progress("record", before + kept, demos * len(tasks), None))
            record(f"robosuite:{task}", episodes=demos, out=out, seed=int(seed) + i, robot=record_robot,
                   progress=tick)
            files.append(out)
        db = where / f"{name}.db"
        with Library(db) as lib:
            lib.add_files(files, assign="recluster")
            labelled = _label_one_each(lib)
            summary = lib.summary()
        library = {"demonstrations": summary["n_demonstrations"], "primitives": len(summary["primitives"]),
                   "skills": len(summary["skills"])}
        first = int(seed) + EPISODE_SEEDS
        if progress is not None:
            progress("episodes", 0, episodes, 0)
        # stack3: the tower's order is drawn per episode from its seed, a goal no demonstration showed
        report = execute_plan(db, scene, episodes=episodes, seed=first, method=method, replan=replan,
                              goal=_tower_goal if name == "stack3" else None, paths=paths, robot=robot,
                              workers=checked["workers"], scheduler=scheduler, verbose=verbose,
                              planner=checked["planner"],
                              progress=None if progress is None else
                              (lambda done, successes: progress("episodes", done, episodes, successes)))
        rows = report["per_episode"]
    successes, failures = tally(rows)
    # every episode's report says the same of the arms (one library, one arm): the last one's is kept
    return {"experiment": name, "scene": scene, "robot": report["robot"],
            "recorded_on": report["recorded_on"], "notes": report["notes"], "method": method,
            "planner": checked["planner"], "timing": report["timing"],
            "seed": int(seed), "demos": demos,
            "episodes": episodes, "successes": successes, "success_rate": successes / episodes,
            "interval": list(binomial_interval(successes, episodes)), "failures": failures,
            "per_episode": rows, "labelled": labelled, "library": library,
            **({"scheduler": report["scheduler"]} if "scheduler" in report else {})}
