"""robosuite demonstrations that hold MuJoCo states, not observations: replayed in robosuite to read them.

Two layouts hold only ``data/demo_K/states`` (MuJoCo's flattened state ``[time, qpos, qvel]``, one row per
control step) and ``actions``:

- **robosuite's raw collection format** (``collect_human_demonstrations.py``, what people record through
  robosuite's own teleoperation): ``data.attrs["env"]`` and ``["env_info"]`` (JSON: robot, controller),
  ``["repository_version"]`` and each demonstration's ``attrs["model_file"]``, the recorded world's MJCF;
- **robomimic files with states but no observations** (``data.attrs["env_args"]``).

Each state is set in robosuite's environment (``set_state_from_flattened``, ``forward``) and the
observations read as robomimic's ``dataset_states_to_obs`` does: the tool pose, the joints, the fingers
and every object's pose. The world is today's robosuite, built from the file's environment name and
robot, never the recorded XML (its asset paths are the recorder's machine's, and MuJoCo is given no path
from a user's file). The recorded world is checked against today's: the recorded MJCF compiled without
any file (meshes and textures dropped: the tool pose depends on the bodies' frames only), its grip site
set to the same states, must agree with today's tool position within :data:`WORLD_TOLERANCE`; where it
does not, ``metadata["world_check"]`` says by how much and where.
"""

from __future__ import annotations

import json
import logging
import re
import warnings
import xml.etree.ElementTree as ET

import numpy as np

from ..core import POSE_OF, Demonstration, matrix_to_quaternion
from ._arms import split_arms
from ._confine import ReadBudget
from ._errors import FormatError, as_file, reading, real_array
from ._h5 import open_h5
from ._lerobot import select_episodes
from ._robomimic import DEFAULT_CONTROL_FREQ, STANDARD_STREAMS, grip_sites

__all__ = ["read_robosuite_raw", "is_states_only", "WORLD_TOLERANCE", "import_robosuite", "robosuite_objects",
           "with_object_poses", "reported_body"]

#: Largest distance (m) between the tool in the recorded world and in today's robosuite, same states.
WORLD_TOLERANCE = 1e-3
#: The observations kept: each arm's (as skillbank's recorder keeps them; ``robot1_...`` for a second arm)
#: and every object's pose.
ROBOT_OBS = ("robot0_eef_pos", "robot0_eef_quat", "robot0_joint_pos", "robot0_gripper_qpos")
#: Largest recorded MJCF read for the world check (bytes); robosuite's worlds are 30-200 kB.
MAX_MODEL_BYTES = 8 << 20
#: The environment keywords taken from a file (the world's; controllers and rendering are not needed to
#: set states).
_WORLD_KWARGS = ("robots", "gripper_types", "env_configuration", "table_full_size", "table_offset")
_DEMO = re.compile(r"^demo_(\d+)$")
MISSING_ROBOSUITE = ("reading robosuite's recorded states replays them in robosuite: pip install "
                     "'skillbank[sim]'")


def is_states_only(h5) -> bool:
    """A ``data/demo_K`` layout whose demonstrations hold ``states`` and no ``obs`` (raw robosuite, or a
    robomimic file before ``dataset_states_to_obs``)."""
    data = h5.get("data")
    if not hasattr(data, "keys"):
        return False
    demos = [data[k] for k in data.keys() if _DEMO.match(k)]
    return bool(demos) and all(hasattr(g, "keys") and "states" in g and "obs" not in g for g in demos)


def _json_attr(path, data, key):
    raw = data.attrs.get(key)
    if raw is None:
        return None
    with reading(path, f"invalid JSON in data.attrs[{key!r}]"):
        value = json.loads(raw.decode() if isinstance(raw, bytes) else str(raw))
    if not isinstance(value, dict):
        raise FormatError(path, f"expected data.attrs[{key!r}] to be a JSON object, found "
                          f"{type(value).__name__}")
    return value


def _environment(path, data) -> tuple[str, dict]:
    """The environment's name and the world's keywords, from ``env_info`` (raw) or ``env_args``."""
    info = _json_attr(path, data, "env_info")
    args = _json_attr(path, data, "env_args")
    if info is not None:
        name, kwargs = info.get("env_name") or data.attrs.get("env"), info
    elif args is not None:
        name, kwargs = args.get("env_name"), args.get("env_kwargs") or {}
    else:
        raise FormatError(path, "expected data.attrs['env_info'] (robosuite's raw format) or "
                          "data.attrs['env_args'] (robomimic) naming the environment, found neither")
    if isinstance(name, bytes):
        name = name.decode()
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]{0,63}", name):
        raise FormatError(path, f"expected an environment name, found {name!r}")
    world = {k: kwargs[k] for k in _WORLD_KWARGS if k in kwargs}
    robots = world.get("robots")
    if isinstance(robots, str):
        robots = [robots]
    if not (isinstance(robots, list) and robots and all(isinstance(r, str) and r.isidentifier()
                                                        for r in robots)):
        raise FormatError(path, f"expected the recorded robot(s) in the environment's 'robots', found "
                          f"{robots!r}")
    world["robots"] = robots
    return name, world


def import_robosuite(missing: str = MISSING_ROBOSUITE):
    """The ``robosuite`` module, quiet, or an ImportError of one line (``missing``) naming the extra.

    robosuite logs its set-up through its ``robosuite_logs`` logger: at import (no private macro file,
    optional robots, mink's IK, controller files) and at every environment made. That is not skillbank's
    output, so unless the root logger asks for INFO or more (``logging.basicConfig(level=INFO)``, which the
    commands' ``-v`` sets) the logger stays off, and the Python warnings its import raises are dropped too
    (the warnings filters are restored after the import).
    """
    quiet = logging.getLogger().getEffectiveLevel() > logging.INFO
    if quiet:
        logging.getLogger("robosuite_logs").disabled = True
    try:
        with warnings.catch_warnings():
            if quiet:
                warnings.simplefilter("ignore")
            import robosuite  # the optional extra skillbank[sim]: only when an environment is made
    except ImportError:
        raise ImportError(missing) from None
    return robosuite


def _make(path, name, world):
    robosuite = import_robosuite()
    if name not in robosuite.ALL_ENVIRONMENTS:
        raise FormatError(path, f"the environment {name!r} is not one of robosuite's "
                          f"({', '.join(sorted(robosuite.ALL_ENVIRONMENTS)[:8])}, ...)")
    try:
        env = robosuite.make(name, **world, has_renderer=False, has_offscreen_renderer=False,
                             use_camera_obs=False, ignore_done=True, control_freq=int(DEFAULT_CONTROL_FREQ))
    except Exception as exc:  # robosuite raises anything for a world it cannot build
        raise FormatError(path, f"robosuite cannot build {name} with {world}: {str(exc)[:200]}") from None
    env.reset()
    return env


def robosuite_objects(obs) -> list:
    """Every object with a pose in robosuite's observations (``X_pos`` and ``X_quat``, not the robot's,
    not the relative poses ``X_to_Y_pos``): what the readers and the recorders keep."""
    return sorted(k[:-4] for k in obs if k.endswith("_pos") and not k.startswith("robot")
                  and "_to_" not in k and f"{k[:-4]}_quat" in obs)


def _position_only(obs) -> list:
    """The objects robosuite reports a position of and no orientation (``X_pos``, no ``X_quat``)."""
    return [k[:-4] for k in obs if k.endswith("_pos") and not k.startswith("robot") and "_to_" not in k
            and f"{k[:-4]}_quat" not in obs and np.size(obs[k]) == 3]


def with_object_poses(env, obs) -> dict:
    """``obs`` with the orientation of every object whose observables give only its position.

    robosuite's ``Door`` reports ``door_pos`` and ``handle_pos`` (a body's and a site's positions) and no
    orientation: a skill cannot be kept on a handle whose turn it never saw. The body or site of the
    simulator's model that stands at the reported position (within a micrometre) is the one reported,
    and its orientation is added as ``X_quat`` (x, y, z, w); a position no body or site stands at gets
    none (it is not an object's pose). Observations that already hold every object's pose are returned
    as they are.

    Examples
    --------
    >>> with_object_poses(None, {"cube_pos": [0, 0, 0], "cube_quat": [0, 0, 0, 1]})["cube_quat"]
    [0, 0, 0, 1]
    """
    missing = _position_only(obs)
    if not missing:
        return obs
    data = env.sim.data._data  # MuJoCo's own data: positions and frames of every body and site
    out = dict(obs)
    for name in missing:
        found = _reported(data, obs[name + "_pos"])
        if found is not None:
            turns = data.xmat if found[0] == "body" else data.site_xmat
            out[name + "_quat"] = matrix_to_quaternion(np.asarray(turns[found[1]], float).reshape(3, 3))
    return out


def _reported(data, position):
    """``("body" | "site", id)`` of what stands at ``position`` (within a micrometre), or None."""
    p = np.asarray(position, float).reshape(3)
    for kind, where in (("body", data.xpos), ("site", data.site_xpos)):
        if len(where) == 0:
            continue
        gap = np.linalg.norm(np.asarray(where) - p, axis=1)
        i = int(np.argmin(gap))
        if gap[i] < 1e-6:
            return kind, i
    return None


def reported_body(env, obs, name):
    """The id of the simulator's body whose pose the observations report as object ``name`` (``X_pos``:
    a body's origin or a site on it), or None where nothing stands there.

    Examples
    --------
    >>> reported_body(None, {}, "cube") is None
    True
    """
    if f"{name}_pos" not in obs:
        return None
    data = env.sim.data._data
    found = _reported(data, obs[f"{name}_pos"])
    if found is None:
        return None
    return int(found[1]) if found[0] == "body" else int(env.sim.model._model.site_bodyid[found[1]])


def _replay(env, states) -> dict:
    """Observations at each state: ``{key: (n, d)}``."""
    sim = env.sim
    rows = []
    for s in states:
        sim.set_state_from_flattened(s)
        sim.forward()
        rows.append(with_object_poses(env, env._get_observations(force_update=True)))
    keys = [k.replace("robot0_", f"robot{i}_") for i in range(len(env.robots)) for k in ROBOT_OBS]
    keys = [k for k in keys if k in rows[0]]
    keys += [f"{o}_{part}" for o in robosuite_objects(rows[0]) for part in ("pos", "quat")]
    return {k: np.stack([np.asarray(r[k], float).reshape(-1) for r in rows]) for k in keys}


def _kinematic_world(path, xml: str):
    """The recorded MJCF compiled with no file: meshes, textures and includes dropped (frames only)."""
    import mujoco  # installed with robosuite

    if "<!DOCTYPE" in xml or "<!ENTITY" in xml:
        raise FormatError(path, "the recorded model_file declares a DOCTYPE or entities; refused")
    try:
        root = ET.fromstring(xml)
    except ET.ParseError as exc:
        raise FormatError(path, f"the recorded model_file is not well-formed XML ({exc})") from None
    if root.tag != "mujoco" or root.find(".//include") is not None:
        raise FormatError(path, "expected the recorded model_file to be one MJCF document without <include>")
    for parent in list(root.iter()):
        for child in list(parent):
            # every element that names a file, and the geoms that draw them: nothing is read from disk
            if child.get("file") is not None or any(k.startswith("file") for k in child.attrib) or \
                    child.tag in ("mesh", "hfield", "skin") or child.get("mesh") or child.get("hfield"):
                parent.remove(child)
            elif child.tag == "material":
                child.attrib.pop("texture", None)
    for compiler in root.iter("compiler"):
        for key in ("meshdir", "texturedir", "assetdir"):
            compiler.attrib.pop(key, None)
        compiler.set("boundmass", "1e-6")
        compiler.set("boundinertia", "1e-9")
    try:
        model = mujoco.MjModel.from_xml_string(ET.tostring(root, encoding="unicode"))
    except ValueError as exc:
        return None, f"the recorded world does not compile without its files ({str(exc)[:120]})"
    return model, None


def _world_check(path, env, xml, states, tool) -> dict:
    """Where the recorded world's grip site is, against today's tool position, at the same states."""
    import mujoco  # installed with robosuite

    model, why = _kinematic_world(path, xml)
    if model is None:
        return {"checked": False, "why": why}
    sites = [model.site(i).name for i in range(model.nsite)]
    grip = [s for s in sites if s.startswith("gripper0") and s.endswith("grip_site")]
    if len(grip) != 1:
        return {"checked": False, "why": f"the recorded world has {len(grip)} gripper grip sites"}
    if model.nq + model.nv + 1 != states.shape[1]:
        return {"checked": False, "why": f"the recorded world has {model.nq} + {model.nv} state values, the "
                                         f"states {states.shape[1] - 1}"}
    data = mujoco.MjData(model)
    site = model.site(grip[0]).id
    recorded = np.empty((len(states), 3))
    for k, s in enumerate(states):
        data.qpos[:] = s[1:1 + model.nq]
        mujoco.mj_kinematics(model, data)
        recorded[k] = data.site_xpos[site]
    gap = np.linalg.norm(recorded - tool, axis=1)
    worst = int(np.argmax(gap))
    return {"checked": True, "max_tool_gap": float(gap[worst]), "at_sample": worst,
            "agrees": bool(gap[worst] <= WORLD_TOLERANCE)}


def read_robosuite_raw(path, *, episodes=None, check_world: bool = True) -> list[Demonstration]:
    """Read demonstrations recorded as MuJoCo states, replaying each state in robosuite.

    Parameters
    ----------
    path : str or path-like
        robosuite's raw collection file, or a robomimic file with states and no observations.
    episodes : None, int, list of int, range, slice or str, optional
        Which demonstrations, by their number ``K`` of ``demo_K``; default all.
    check_world : bool, default=True
        Compare the recorded world (``model_file``) with today's robosuite at every state.

    Returns
    -------
    list of Demonstration
        The streams of :func:`~skillbank.io.read_robomimic` for a file skillbank's recorder wrote:
        ``position`` and ``orientation`` (the tool, ``robot0_eef_*``), ``gripper`` (the finger joints),
        ``robot0_joint_pos``, every object's ``X_pos`` and ``X_quat``, and ``actions``; at 20 Hz.
        Metadata: ``source``, ``format`` (``"robosuite-raw"``), ``demo``, ``episode``, ``label`` (the
        environment), ``arm`` (the recorded robot), ``pose_of`` (its gripper's grip site),
        ``rate_hz``, ``robosuite_version`` (the recorder's) and ``world_check``.

    Raises
    ------
    FormatError
        No environment named, states whose size is not the environment's, a world robosuite cannot
        build.
    ImportError
        Without robosuite (extra ``sim``), one line naming it.

    Examples
    --------
    >>> demos = read_robosuite_raw("human/lift_panda_teleop.hdf5")  # doctest: +SKIP
    >>> demos[0].metadata["arm"], demos[0]["position"].shape  # doctest: +SKIP
    ('Panda', (482, 3))
    """
    p = as_file(path)
    budget = ReadBudget(p)
    with open_h5(p) as h5:
        if not is_states_only(h5):
            raise FormatError(p, "expected data/demo_K groups holding 'states' and no 'obs'")
        data = h5["data"]
        name, world = _environment(p, data)
        numbers = {int(m.group(1)): k for k in data.keys() if (m := _DEMO.match(k))}
        chosen = select_episodes(episodes, numbers)
        version = data.attrs.get("repository_version")
        records = []
        for n in chosen:
            group = data[numbers[n]]
            states = real_array(p, budget.dataset(group["states"], f"{numbers[n]}/states"),
                                f"'{numbers[n]}/states'")
            if states.ndim != 2 or len(states) == 0:
                raise FormatError(p, f"expected '{numbers[n]}/states' of shape (steps, state size), found "
                                  f"{states.shape}")
            actions = None
            if "actions" in group:
                actions = real_array(p, budget.dataset(group["actions"], f"{numbers[n]}/actions"),
                                     f"'{numbers[n]}/actions'")
            xml = group.attrs.get("model_file")
            if isinstance(xml, bytes):
                xml = xml.decode("utf-8", errors="replace")
            if xml is not None and len(xml) > MAX_MODEL_BYTES:
                raise FormatError(p, f"'{numbers[n]}' model_file has {len(xml)} bytes, more than "
                                  f"{MAX_MODEL_BYTES}")
            records.append((n, numbers[n], states, actions, xml))
    env = _make(p, name, world)
    try:
        size = env.sim.get_state().flatten().shape[0]
        out = []
        for n, group_name, states, actions, xml in records:
            if states.shape[1] != size:
                raise FormatError(p, f"'{group_name}/states' holds {states.shape[1]} values a step, and "
                                  f"robosuite's {name} with {world['robots']} has {size}: recorded in "
                                  "another world (another robot, gripper or objects)")
            obs = _replay(env, states)
            check = ({"checked": False, "why": "not asked"} if not check_world else
                     {"checked": False, "why": "the file records no model_file"} if xml is None else
                     _world_check(p, env, xml, states, obs["robot0_eef_pos"]))
            out.extend(_demonstration(p, group_name, n, obs, actions, name, world, version, check))
    finally:
        env.close()
    return out


def _demonstration(p, group_name, number, obs, actions, name, world, version, check) -> list:
    """The recorded episode's demonstrations: one per arm (:func:`~skillbank.io.split_arms`)."""
    streams = dict(obs)
    metadata = {"source": str(p), "format": "robosuite-raw", "demo": group_name, "episode": number,
                "label": name, "arm": world["robots"][0], "rate_hz": DEFAULT_CONTROL_FREQ,
                "rate_from": "default", "world_check": check}
    if version is not None:
        metadata["robosuite_version"] = str(version.decode() if isinstance(version, bytes) else version)
    points = grip_sites(world["robots"], world.get("gripper_types", "default"))
    if points[0] is not None:
        metadata[POSE_OF] = points[0]
    if actions is not None and len(actions) == len(next(iter(obs.values()))):
        streams["actions"] = actions
    for stream, key, _ in STANDARD_STREAMS:
        if key in streams:
            streams[stream] = streams.pop(key)
            metadata.setdefault("renamed", {})[key] = stream
    n = len(streams["position"])
    with reading(p, f"invalid demonstration '{group_name}'"):
        demo = Demonstration(np.arange(n) / DEFAULT_CONTROL_FREQ, streams, metadata)
        return split_arms(demo, robots=world["robots"], pose_of=points)
