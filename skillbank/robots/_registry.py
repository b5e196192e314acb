"""The registry of robot models: the one list of robot names.

A name maps to a built-in model class (``ur5e``: the analytic UR5e) or to a
description the project loads offline (``panda`` and robosuite's other arms:
the MJCF that robosuite's wheel ships, extra ``sim``; docs/robots.md records
their source and licence). :func:`robot_model` also takes a description
file's path. Adding a robot is one line here.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ._base import RobotModel
from ._ur5e import UR5e

__all__ = ["ROBOTS", "DESCRIPTIONS", "RegisteredDescription", "robot_model", "registered_name"]


class RegisteredDescription(NamedTuple):
    """A description shipped by an installed package, with what the file does not say.

    Attributes
    ----------
    package, path : str
        The package and the file inside it.
    tool_frame : str
        The flange's link.
    home : tuple of float
        The ready pose (where robosuite starts the arm).
    max_velocity, max_acceleration : tuple of float or None
        The manufacturer's joint limits (rad/s, rad/s^2), which MJCF does not carry.
    source : str
    tool : tuple of 3 float
        The default tool point in the flange frame (metres): where the arm's usual gripper works.
    gripper : str or None
        The gripper mounted by default (a name in :data:`~skillbank.robots.GRIPPERS`), or None.
    """

    package: str
    path: str
    tool_frame: str
    home: tuple
    max_velocity: tuple | None = None
    max_acceleration: tuple | None = None
    source: str = ""
    tool: tuple = (0.0, 0.0, 0.0)
    gripper: str | None = None


#: Registered descriptions. Panda: robosuite 1.5.2's MJCF (MIT), its ``init_qpos`` as home, Franka's
#: published joint velocity and acceleration limits (Franka Control Interface documentation, "Robot and
#: interface specifications"), as tool point robosuite's Panda gripper's grip site, 0.097 m along the
#: flange's z (``grippers/panda_gripper.xml``, body ``eef``): where robosuite records the Panda's pose,
#: and the Franka hand (``PANDA_HAND``, robosuite's same file) mounted on the flange.
DESCRIPTIONS: dict[str, RegisteredDescription] = {
    "panda": RegisteredDescription(
        "robosuite", "models/assets/robots/panda/robot.xml", "right_hand",
        (0.0, np.pi / 16.0, 0.0, -np.pi / 2.0 - np.pi / 3.0, 0.0, np.pi - 0.2, np.pi / 4),
        (2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61), (15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0),
        "robosuite 1.5.2 models/assets/robots/panda (MIT); limits: Franka Control Interface specifications",
        (0.0, 0.0, 0.097), "panda_hand"),
}

#: Robot name (as on the command line) -> a built-in model class. Descriptions are in DESCRIPTIONS.
ROBOTS: dict[str, type[RobotModel]] = {
    "ur5e": UR5e,
}


def _package_file(package: str, path: str) -> Path:
    spec = importlib.util.find_spec(package)  # found, not imported: robosuite's import costs seconds
    if spec is None or not spec.submodule_search_locations:
        raise ValueError(f"robot: the registered description comes with {package}, which is not installed: "
                         "pip install 'skillbank[sim]'")
    return Path(list(spec.submodule_search_locations)[0]) / path


def _described(path, *, tool_frame=None, name=None, registered=None, **params) -> RobotModel:
    from ._chain import ChainModel  # numpy only; loaded when a description is asked for
    from ._description import load_description  # imports mujoco (extra "sim") when it reads the file

    chain = load_description(path, tool_frame=tool_frame, name=name)
    if registered is not None:
        chain = chain._replace(home=registered.home, gripper=registered.gripper)
        if params.get("tool") is None and any(registered.tool):
            params["tool"] = np.eye(4)
            params["tool"][:3, 3] = registered.tool
    model = ChainModel(chain, **params)
    if registered is not None:
        model.max_velocity, model.max_acceleration = registered.max_velocity, registered.max_acceleration
    return model


def registered_name(name):
    """``name`` as the registry spells it (``"Panda"``, ``"UR5E"``: ``"panda"``, ``"ur5e"``), else as given.

    Robot names are case-insensitive everywhere (the command line's ``--robot``, ``robot=``): this is the
    one place they are normalised. Anything that is not a registered name (a description file's path)
    is returned as given.

    Examples
    --------
    >>> registered_name("UR5e"), registered_name("Panda"), registered_name("arm.urdf")
    ('ur5e', 'panda', 'arm.urdf')
    """
    if isinstance(name, str):
        key = name.strip().lower()
        if key in ROBOTS or key in DESCRIPTIONS:
            return key
    return name


def robot_model(name, **params) -> RobotModel:
    """The model registered as ``name``, or read from the description file at path ``name``.

    Parameters
    ----------
    name : str or path-like
        ``"ur5e"``, a name in :data:`DESCRIPTIONS` (``"panda"``) or a URDF / MJCF file. Names are
        case-insensitive (``"UR5e"``, ``"Panda"``; :func:`registered_name`).
    **params
        The model's parameters (``base``, ``tool``, ...); for a description also ``tool_frame``
        (the flange's link or site).

    Examples
    --------
    >>> robot_model("ur5e").joint_names[0]
    'shoulder_pan_joint'
    >>> robot_model("panda").n_joints
    7
    >>> robot_model("UR5e").name
    'ur5e'
    """
    name = registered_name(name)
    if isinstance(name, str) and name in ROBOTS:
        if params.get("tool_frame") is not None:
            raise ValueError(f"tool frame: {name} is a built-in model whose flange is fixed; give tool=... "
                             "for the tool, or a description file to name a link")
        params.pop("tool_frame", None)
        return ROBOTS[name](**params)
    if isinstance(name, str) and name in DESCRIPTIONS:
        reg = DESCRIPTIONS[name]
        if params.get("tool_frame") is None:
            params["tool_frame"] = reg.tool_frame
        return _described(_package_file(reg.package, reg.path), name=name, registered=reg, **params)
    if isinstance(name, (str, Path)) and (Path(name).suffix.lower() in (".urdf", ".xml", ".mjcf")
                                         or Path(name).is_file()):
        return _described(name, **params)
    raise ValueError(f"robot: expected one of {list(ROBOTS) + list(DESCRIPTIONS)} or a URDF / MJCF file, "
                     f"got {name!r}")
