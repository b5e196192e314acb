"""Human-like demonstrations written in robosuite's raw collection format: ``sim record --style human``.

robosuite's own teleoperation collection (``scripts/collect_human_demonstrations.py``) wraps the
environment in ``robosuite.wrappers.DataCollectionWrapper``, which keeps each episode's model XML
and flattened MuJoCo states and actions in a folder of ``.npz`` files, and then gathers the
successful episodes into one HDF5 file: ``data/demo_K`` (K from 1) with ``states`` (the state
before each action), ``actions`` and ``attrs["model_file"]``, and ``data.attrs`` ``date``,
``time``, ``repository_version``, ``env`` and ``env_info`` (JSON: ``env_name``, ``robots``,
``controller_configs``). :func:`record_human` drives the same wrapper with a
:class:`~skillbank.simulation._human.HumanDemonstrator` and gathers its folders the same way
(written here, not robosuite's script, which is not importable as a library).
"""

from __future__ import annotations

import contextlib
import datetime
import io
import json
import logging
import shutil
import tempfile
from pathlib import Path

import numpy as np

from ..core._validation import check_positive
from ._human import MULTI_TASKS, HumanDemonstrator
from ._robosuite import CONTROL_FREQ, TASKS, import_robosuite, parse_env, robosuite_robot

__all__ = ["record_human", "quiet_robosuite", "command_statistics"]

#: The recorder's styles (``sim record --style``).
STYLES = ("scripted", "human")


@contextlib.contextmanager
def quiet_robosuite(quiet: bool = True):
    """Within the block, robosuite's logger is silent (its warnings at import, its INFO lines at each
    environment), and its lines on stdout are dropped; as they were afterwards. ``quiet=False``: as is.

    Examples
    --------
    >>> with quiet_robosuite():
    ...     print("dropped")
    """
    if not quiet:
        yield
        return
    logger = logging.getLogger("robosuite_logs")
    was = logger.disabled
    logger.disabled = True
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            yield
    finally:
        logger.disabled = was


def parse_task(spec) -> str:
    """The task of ``robosuite:TASK``: a key of ``TASKS`` or of ``MULTI_TASKS`` (several objects).

    Examples
    --------
    >>> parse_task("robosuite:PickPlace")
    'PickPlace'
    """
    return parse_env(spec, sorted(TASKS) + sorted(MULTI_TASKS))


def command_statistics(actions) -> dict:
    """How a demonstration's commands look: keyboard-like pulses or a smooth stream.

    ``actions``: (n, 7) ``OSC_POSE`` deltas and the gripper (robosuite's layout). Returns
    ``{"steps", "bursts"`` (runs of control steps with a motion command), ``"idle"`` (the fraction
    of steps with none), ``"gap_median"``, ``"gap_max"`` (control steps between bursts),
    ``"corrections"`` (a key followed by its opposite), ``"turn_taps"`` (steps turning the wrist),
    ``"closes"`` (the gripper closed), ``"first_key"`` (the step of the first motion command)}.

    Examples
    --------
    >>> a = np.zeros((10, 7)); a[[2, 3, 7], 0] = [1, 1, -1]
    >>> s = command_statistics(a)
    >>> s["bursts"], s["idle"], s["corrections"], s["first_key"]
    (2, 0.7, 1, 2)
    """
    a = np.asarray(actions, float)
    if a.ndim != 2 or a.shape[1] != 7 or not len(a):
        raise ValueError(f"actions: expected an array (n, 7), got shape {a.shape}")
    motion = np.any(a[:, :6] != 0, axis=1)
    starts = np.flatnonzero(motion & ~np.r_[False, motion[:-1]])
    ends = np.flatnonzero(motion & ~np.r_[motion[1:], False])
    gaps = starts[1:] - ends[:-1] - 1
    keys = [(int(k), float(np.sign(row[k]))) for row in a[motion] for k in np.flatnonzero(row[:6])]
    return {"steps": len(a), "bursts": len(starts), "idle": float(1 - motion.mean()),
            "gap_median": float(np.median(gaps)) if len(gaps) else 0.0,
            "gap_max": int(gaps.max()) if len(gaps) else 0,
            "corrections": sum(k == j and s == -t for (k, s), (j, t) in zip(keys, keys[1:], strict=False)),
            "turn_taps": int(np.count_nonzero(np.any(a[:, 3:6] != 0, axis=1))),
            "closes": int(np.count_nonzero(np.diff(a[:, 6]) > 0) + (a[0, 6] > 0)),
            "first_key": int(starts[0]) if len(starts) else None}


def _check_seed(seed) -> int:
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or not 0 <= seed < 2 ** 32:
        raise ValueError(f"seed: expected an integer in [0, 2**32 - 1], got {seed!r}")
    return int(seed)


def _load(path: Path) -> dict:
    # the wrapper's own files in our private temporary folder, just written: its ``action_infos`` are a
    # list of dicts, which numpy stores pickled (never done for a user's file)
    with np.load(path, allow_pickle=True) as npz:
        return {"states": np.asarray(npz["states"], float), "env": str(npz["env"]),
                "actions": [np.asarray(info["actions"], float) for info in npz["action_infos"]]}


def _gather(folder: Path) -> dict:
    """One episode's folder, as the wrapper left it: ``{"model", "states", "actions", "env"}``."""
    parts = sorted(folder.glob("state_*.npz"), key=lambda p: float(p.stem.split("_", 1)[1].replace("_", ".")))
    states, actions, env = [], [], None
    for part in parts:
        chunk = _load(part)
        states.extend(chunk["states"])
        actions.extend(chunk["actions"])
        env = chunk["env"]
    # the wrapper keeps the state after the last action too: the raw format has one state per action
    states = states[:-1]
    if len(states) != len(actions):
        raise ValueError(f"{folder}: {len(states)} states for {len(actions)} actions")
    return {"model": (folder / "model.xml").read_text(), "states": np.stack(states),
            "actions": np.stack(actions), "env": env}


def record_human(env: str, *, episodes: int, out, seed: int = 0, robot: str = "UR5e", max_tries=None,
                 progress=None, demonstrator: HumanDemonstrator | None = None, when=None,
                 verbose: bool = False) -> dict:
    """Record ``episodes`` successful human-like demonstrations of ``env`` in robosuite's raw format.

    Parameters
    ----------
    env : str
        ``robosuite:TASK``, TASK a key of :data:`~skillbank.simulation.TASKS`, or ``PickPlace`` (its
        four objects into their bins) or ``NutAssembly`` (both nuts on their pegs) in one demonstration.
    episodes : int
        Successful episodes to keep (the environment's ``_check_success()`` held at the end).
    out : path-like
        The HDF5 file written; it must not exist. Written to ``out.part`` and renamed when whole.
    seed : int, default=0
        Seeds robosuite's placements and the person (``demonstrator.random_state`` is not used).
    robot : str, default="UR5e"
        robosuite's arm, with its default gripper and controller (``OSC_POSE``, delta inputs).
    max_tries : int, optional
        Episodes run at most (default ``3 * episodes``); fewer successes write nothing.
    progress : callable, optional
        ``progress(kept, tried)`` after each episode.
    demonstrator : HumanDemonstrator, optional
        The person's habits (default: :class:`HumanDemonstrator`'s defaults).
    when : datetime.datetime, optional
        The ``date`` and ``time`` written (default: now); the rest of the file is the seed's alone.
    verbose : bool, default=False
        Let robosuite's log and the wrapper's lines through.

    Returns
    -------
    dict
        ``{"env", "style", "episodes", "tried", "seed", "out", "samples", "robot"}``.

    Examples
    --------
    >>> record_human("robosuite:Lift", episodes=1, out="lift_human.hdf5", robot="Panda")  # doctest: +SKIP
    """
    task = parse_task(env)
    robot = robosuite_robot(robot)
    episodes = check_positive(episodes, name="episodes", integer=True)
    tries = 3 * episodes if max_tries is None else check_positive(max_tries, name="max_tries", integer=True)
    seed = _check_seed(seed)
    person = HumanDemonstrator() if demonstrator is None else demonstrator
    if not isinstance(person, HumanDemonstrator):
        raise ValueError(f"demonstrator: expected a HumanDemonstrator, got {type(person).__name__}")
    person.check()
    if when is not None and not isinstance(when, datetime.datetime):
        raise ValueError(f"when: expected a datetime.datetime, got {when!r}")
    out = Path(out)
    if out.exists() or out.is_symlink():
        raise ValueError(f"out: {out} exists; give a new file")
    if not out.parent.is_dir():
        raise ValueError(f"out: the folder {out.parent} does not exist")
    rng = np.random.default_rng(seed)
    kept, tried = [], 0
    folder = Path(tempfile.mkdtemp(prefix="skillbank-human-"))
    try:
        # robosuite logs, and prints on stdout (its gym wrapper at import, the collection wrapper at
        # each episode): off unless verbose
        with quiet_robosuite(not verbose):
            suite = import_robosuite()  # the extra skillbank[sim], only when episodes are recorded
            from robosuite.controllers import load_composite_controller_config  # after its check
            from robosuite.wrappers import DataCollectionWrapper  # after its check

            controller = load_composite_controller_config(robot=robot)
            info = {"env_name": task, "robots": [robot], "controller_configs": controller}
            base = suite.make(task, robots=[robot], controller_configs=controller, control_freq=CONTROL_FREQ,
                              horizon=10 ** 6, seed=seed, has_renderer=False, has_offscreen_renderer=False,
                              use_camera_obs=False, ignore_done=True, reward_shaping=True)
            wrapped = DataCollectionWrapper(base, str(folder / "raw"))
            try:
                while len(kept) < episodes and tried < tries:
                    ok = person.episode(wrapped, task, rng)
                    tried += 1
                    if ok:
                        kept.append(Path(wrapped.ep_directory))
                    if progress is not None:
                        progress(len(kept), tried)
            finally:
                wrapped.close()  # flushes the last episode's states
        if len(kept) < episodes:
            raise ValueError(f"{env}: only {len(kept)} of {tried} human-like episodes succeeded, {episodes} "
                             "were asked; nothing was written (try another --seed)")
        demos = [_gather(ep) for ep in kept]
        total = _write(out, demos, info, when or datetime.datetime.now(), suite.__version__)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return {"env": env, "style": "human", "episodes": len(kept), "tried": tried, "seed": seed,
            "out": str(out), "samples": total, "robot": robot}


def _write(out: Path, demos: list, info: dict, when, version: str) -> int:
    import h5py  # core dependency; only when a file is written

    part = out.with_name(out.name + ".part")
    try:
        with h5py.File(part, "w") as h5:
            data = h5.create_group("data")
            for k, demo in enumerate(demos, start=1):  # robosuite numbers its demonstrations from 1
                g = data.create_group(f"demo_{k}")
                g.attrs["model_file"] = demo["model"]
                g.create_dataset("states", data=demo["states"])
                g.create_dataset("actions", data=demo["actions"])
            data.attrs["date"] = f"{when.month}-{when.day}-{when.year}"
            data.attrs["time"] = f"{when.hour}:{when.minute}:{when.second}"
            data.attrs["repository_version"] = version
            data.attrs["env"] = demos[0]["env"]
            data.attrs["env_info"] = json.dumps(info)
        if out.exists() or out.is_symlink():  # made meanwhile: never overwritten
            raise ValueError(f"out: {out} exists; give a new file")
        part.replace(out)
    except BaseException:
        part.unlink(missing_ok=True)
        raise
    return int(sum(len(d["actions"]) for d in demos))
