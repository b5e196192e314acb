"""Reader for robomimic HDF5 datasets: ``data/demo_N/obs/<key>`` and ``data/demo_N/actions``."""

from __future__ import annotations

import json
import re

import numpy as np

from ..core import POSE_OF, Demonstration, check_pose_of
from ..core._pose_point import offset_pose_of
from ..core._validation import check_positive, summarise
from ._arms import split_arms
from ._confine import ReadBudget
from ._errors import FormatError, as_file, reading, real_array
from ._h5 import open_h5
from ._lerobot import select_episodes

__all__ = ["read_robomimic", "ROBOMIMIC_GROUP", "is_robomimic", "DEFAULT_CONTROL_FREQ", "ROBOSUITE_POSE_OF"]

#: The group that holds the demonstrations.
ROBOMIMIC_GROUP = "data"
#: robosuite's default control rate, used when the file does not record one (Hz).
DEFAULT_CONTROL_FREQ = 20.0
_DEMO = re.compile(r"^demo_(\d+)$")


def is_robomimic(h5) -> bool:
    """Whether an open HDF5 file has robomimic's layout: a group ``data`` with ``demo_N`` groups."""
    group = h5.get(ROBOMIMIC_GROUP)
    return hasattr(group, "keys") and any(_DEMO.match(k) for k in group.keys())


def _env_args(path, data) -> dict:
    raw = data.attrs.get("env_args")
    if raw is None:
        return {}
    with reading(path, "invalid JSON in data.attrs['env_args']"):
        args = json.loads(raw.decode() if isinstance(raw, bytes) else str(raw))
    return args if isinstance(args, dict) else {}


#: The point robosuite reports as ``robot0_eef_pos`` for an arm with its default gripper: the gripper's
#: grip site (robosuite 1.5 takes ``robot0_eef_quat`` from the flange body, whose axes the grip site shares
#: on these arms; tests/simulation/test_panda.py reads both with robosuite).
ROBOSUITE_POSE_OF = {"panda": "panda_hand:grip_site", "ur5e": "robotiq_2f85:grip_site"}


def grip_sites(robots, grippers="default") -> list:
    """The point each of robosuite's arms ``robots`` reports as ``robotK_eef_pos``: its default gripper's
    grip site (:data:`ROBOSUITE_POSE_OF`; None for an arm not listed there), or None for every arm when
    ``grippers`` (robosuite's ``gripper_types``) names grippers other than the defaults.

    Examples
    --------
    >>> grip_sites(["Panda", "Panda"]), grip_sites(["Panda"], ["Robotiq85Gripper"])
    (['panda_hand:grip_site', 'panda_hand:grip_site'], [None])
    """
    default = grippers in ("default", None) or grippers == ["default"] * len(robots)
    return [ROBOSUITE_POSE_OF.get(r.lower()) if default else None for r in robots]


def _pose_of(path, data, env_args):
    """Which point the file's ``robot0_eef_*`` poses are of, as the file states it, else None.

    skillbank's recorder writes ``data.attrs["robot"]`` (``pose_of``, and ``tool``: the point's pose in the
    flange body); robosuite's own collections name the robot in ``env_args``, whose default gripper's grip
    site is the point (another gripper: unknown).
    """
    raw = data.attrs.get("robot")
    if raw is not None:
        with reading(path, "invalid JSON in data.attrs['robot']"):
            robot = json.loads(raw.decode() if isinstance(raw, bytes) else str(raw))
        if isinstance(robot, dict) and isinstance(robot.get("pose_of"), str):
            return check_pose_of(robot["pose_of"], name=f"{path}: data.attrs['robot']['pose_of']")
        tool = np.asarray(robot.get("tool"), float) if isinstance(robot, dict) and "tool" in robot else None
        if tool is not None and tool.shape == (4, 4) and np.isfinite(tool).all():
            return offset_pose_of(tool, name=f"{path}: data.attrs['robot']['tool']")
    kwargs = env_args.get("env_kwargs") or {}
    robots = kwargs.get("robots")
    robots = [robots] if isinstance(robots, str) else robots
    if isinstance(robots, list) and len(robots) == 1 and isinstance(robots[0], str):
        return grip_sites(robots, kwargs.get("gripper_types", "default"))[0]
    return None


def _arm(path, data, env_args):
    """The one arm the file says it was recorded on (skillbank's recorder, else ``env_args``), or None."""
    raw = data.attrs.get("robot")
    if raw is not None:
        with reading(path, "invalid JSON in data.attrs['robot']"):
            robot = json.loads(raw.decode() if isinstance(raw, bytes) else str(raw))
        if isinstance(robot, dict) and isinstance(robot.get("name"), str):
            return robot["name"]
    robots = (env_args.get("env_kwargs") or {}).get("robots")
    robots = [robots] if isinstance(robots, str) else robots
    if isinstance(robots, list) and len(robots) == 1 and isinstance(robots[0], str):
        return robots[0]
    return None


def _rate(path, control_freq, env_args) -> tuple[float, str]:
    if control_freq is not None:
        return check_positive(control_freq, name="control_freq"), "argument"
    freq = (env_args.get("env_kwargs") or {}).get("control_freq")
    if freq is None:
        return DEFAULT_CONTROL_FREQ, "default"
    if isinstance(freq, bool) or not isinstance(freq, (int, float)) or not 0 < freq < np.inf:
        raise FormatError(path, f"expected a positive env_args['env_kwargs']['control_freq'], found {freq!r}")
    return float(freq), "env_args"


def read_robomimic(path, *, episodes=None, filter_key=None, obs_keys=None,
                   control_freq=None) -> list[Demonstration]:
    """Read the demonstrations of a robomimic HDF5 dataset, one Demonstration per ``data/demo_N``.

    Parameters
    ----------
    path : str or path-like
        The ``.hdf5`` file.
    episodes : None, int, list of int, range, slice or str, optional
        Which demonstrations, by their number ``N``: ``"0:10"``, ``"3,7"``;
        default all. See :func:`~skillbank.io.select_episodes`.
    filter_key : str, optional
        Only the demonstrations listed in ``mask/<filter_key>`` (for example
        ``"train"`` or ``"valid"``).
    obs_keys : list of str, optional
        Which observations become streams; default every numeric one with
        at most one value axis (camera images are skipped and listed in
        ``metadata["skipped_obs"]``).
    control_freq : float, optional
        The sample rate in Hz (robosuite's name for it). Default: the recorded
        ``env_args["env_kwargs"]["control_freq"]``, else
        :data:`DEFAULT_CONTROL_FREQ`; ``metadata["rate_from"]`` says which.

    Returns
    -------
    list of Demonstration
        Streams: each observation key (``robot0_eef_pos``, ...) and
        ``actions``, except the tool pose and the gripper, read under
        skillbank's names (so that a library adds and cuts them as its
        own): ``robot0_eef_pos`` as ``position``, ``robot0_eef_quat`` (x,
        y, z, w) as ``orientation`` and ``robot0_gripper_qpos`` (the finger
        joints, as recorded) as ``gripper`` (``metadata["renamed"]`` lists
        them).
        ``t = arange(n) / rate``. Metadata: ``source``,
        ``format`` (``"robomimic-h5"``), ``demo`` (the group name),
        ``episode`` (``N``), ``label`` (the environment's name, when
        recorded), ``rate_hz``, ``rate_from``, ``skipped_obs`` and
        ``arm``, the robot it was recorded on, and ``pose_of``, the point of
        the robot the poses are of, where the file says it
        (``data.attrs["robot"]`` of skillbank's recorder; else the
        default gripper's grip site of the one robosuite arm ``env_args``
        names, :data:`ROBOSUITE_POSE_OF`).

    Raises
    ------
    FormatError
        A file that is not HDF5 or lacks the layout, or a demonstration
        whose streams disagree in length.
    ValueError
        A bad ``episodes``, ``filter_key``, ``obs_keys`` or ``control_freq``.

    Examples
    --------
    >>> demos = read_robomimic("lift/ph/low_dim.hdf5", episodes="0:5")  # doctest: +SKIP
    >>> demos[0].metadata["label"], demos[0]["position"].shape[1]  # doctest: +SKIP
    ('Lift', 3)
    """
    p = as_file(path)
    if obs_keys is not None:
        obs_keys = [obs_keys] if isinstance(obs_keys, str) else list(obs_keys)
        if not obs_keys or not all(isinstance(k, str) for k in obs_keys):
            raise ValueError(f"obs_keys: expected a list of observation names, got {obs_keys!r}")
    with open_h5(p) as h5:
        if not is_robomimic(h5):
            raise FormatError(p, f"expected a robomimic dataset (group '{ROBOMIMIC_GROUP}' with demo_N "
                              f"groups), found [{summarise(map(repr, sorted(h5.keys())))}]")
        data = h5[ROBOMIMIC_GROUP]
        budget = ReadBudget(p)
        numbers = {int(m.group(1)): k for k in data.keys() if (m := _DEMO.match(k))}
        if filter_key is not None:
            masks = sorted(h5["mask"].keys()) if "mask" in h5 else []
            if filter_key not in masks:
                raise ValueError(f"filter_key: expected one of {masks}, got {filter_key!r}")
            mask = budget.dataset(h5["mask"][filter_key], f"mask/{filter_key}")
            listed = {v.decode() if isinstance(v, bytes) else str(v) for v in np.ravel(mask)}
            numbers = {n: k for n, k in numbers.items() if k in listed}
        env_args = _env_args(p, data)
        hz, rate_from = _rate(p, control_freq, env_args)
        chosen = select_episodes(episodes, numbers)
        common = {"source": str(p), "format": "robomimic-h5", "rate_hz": hz, "rate_from": rate_from}
        if env_args.get("env_name"):
            common["label"] = str(env_args["env_name"])
        pose_of = _pose_of(p, data, env_args)
        if pose_of is not None:
            common[POSE_OF] = pose_of
        arm = _arm(p, data, env_args)
        if arm is not None:
            common["arm"] = arm
        demos = [_demo(p, data[numbers[n]], numbers[n], n, obs_keys, hz, common, budget) for n in chosen]
        robots, points = _robots(p, data, env_args)
    # a recording of several arms: one demonstration per arm (a library learns each arm's motion)
    return [arm for demo in demos for arm in split_arms(demo, robots=robots, pose_of=points)]


def _robots(path, data, env_args) -> tuple:
    """The recorded arms' names and the point each one's poses are of, by index, for a recording of
    several arms (skillbank's recorder: ``data.attrs["robots"]``; else ``env_args`` and each default
    gripper's grip site); ``(None, None)`` where nothing says."""
    raw = data.attrs.get("robots")
    if raw is not None:
        with reading(path, "invalid JSON in data.attrs['robots']"):
            listed = json.loads(raw.decode() if isinstance(raw, bytes) else str(raw))
        if isinstance(listed, list) and all(isinstance(r, dict) for r in listed):
            return ([r.get("name") for r in listed],
                    [check_pose_of(r["pose_of"], name=f"{path}: data.attrs['robots'][{k}]['pose_of']")
                     if isinstance(r.get("pose_of"), str) else None for k, r in enumerate(listed)])
    kwargs = env_args.get("env_kwargs") or {}
    robots = kwargs.get("robots")
    if not (isinstance(robots, list) and all(isinstance(r, str) for r in robots)):
        return None, None
    return robots, grip_sites(robots, kwargs.get("gripper_types", "default"))


#: skillbank's stream, robosuite's observation of it and its width (None: any): the tool position (m,
#: world frame) and orientation (x, y, z, w, robosuite's order and skillbank's), and the gripper (its
#: finger joints, as recorded: under the name the segmenter knows as discrete, a toggle is a cut),
#: read under skillbank's names.
STANDARD_STREAMS = (("position", "robot0_eef_pos", 3), ("orientation", "robot0_eef_quat", 4),
                    ("gripper", "robot0_gripper_qpos", None))


def _demo(p, group, name, number, obs_keys, hz, common, budget) -> Demonstration:
    obs = group.get("obs")
    available = sorted(obs.keys()) if hasattr(obs, "keys") else []
    if obs_keys is not None:
        unknown = [k for k in obs_keys if k not in available]
        if unknown:
            raise ValueError(f"obs_keys: expected names among {available} (in {name}), got {unknown}")
    raw, skipped = {}, {}
    for key in obs_keys or available:
        dataset = obs[key]
        if dataset.ndim > 2 or dataset.dtype.kind not in "biuf":
            skipped[key] = list(dataset.shape)
            continue
        raw[key] = real_array(p, budget.dataset(dataset, f"{name}/obs/{key}"), f"'{name}/obs/{key}'")
    if "actions" in group:
        actions = budget.dataset(group["actions"], f"{name}/actions")
        raw["actions"] = real_array(p, actions, f"'{name}/actions'")
    if not raw:
        raise FormatError(p, f"expected numeric observations or actions in '{name}', found none")
    lengths = {k: v.shape[0] for k, v in raw.items()}
    if len(set(lengths.values())) != 1 or 0 in lengths.values():
        raise FormatError(p, f"expected the streams of '{name}' to have one non-zero length, found {lengths}")
    n = next(iter(lengths.values()))
    metadata = {**common, "demo": name, "episode": number}
    for stream, key, width in STANDARD_STREAMS:
        # robosuite's tool pose is the pose a library learns: under the name skillbank uses, once (a
        # copy under both names would count twice as evidence for a cut)
        if stream not in raw and key in raw and raw[key].ndim == 2 and width in (None, raw[key].shape[1]):
            raw[stream] = raw.pop(key)
            metadata.setdefault("renamed", {})[key] = stream
    if skipped:
        metadata["skipped_obs"] = skipped
    with reading(p, f"invalid demonstration '{name}'"):
        return Demonstration(np.arange(n) / hz, raw, metadata)
