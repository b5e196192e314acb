"""One demonstration per arm, from a recording of several robosuite arms.

robosuite names each arm's observations by its prefix (``robot0_eef_pos``, ``robot1_eef_pos``, ...) and
concatenates the arms' actions (``TwoArmLift``: 7 + 7 for two arms with ``OSC_POSE`` and a gripper). A
library learns one arm's motion at a time: each arm's demonstration holds that arm's tool pose and
gripper under skillbank's names (``position``, ``orientation``, ``gripper``), its own ``robotK_*``
observations, its own columns of ``actions`` and every object's pose, with ``metadata["arm_index"]``
(``K``) and ``metadata["arms"]`` (how many the recording has). The two demonstrations of one episode share
``source`` and ``episode``: that is how the moments the arms depend on each other are found again
(:func:`skillbank.segmentation.arm_constraints`).
"""

from __future__ import annotations

import re

from ..core import POSE_OF, Demonstration

__all__ = ["split_arms", "arm_count", "arm_of", "ARM_INDEX", "ARM_STREAMS"]

#: Metadata key: which of the recording's arms a demonstration is of (robosuite's ``robotK_``).
ARM_INDEX = "arm_index"
#: skillbank's stream and robosuite's observation suffix of it, per arm.
ARM_STREAMS = (("position", "eef_pos"), ("orientation", "eef_quat"), ("gripper", "gripper_qpos"))
_ROBOT = re.compile(r"^robot(\d+)_")


def arm_count(streams) -> int:
    """How many arms a recording's streams name (``robotK_eef_pos`` for K from 0; arm 0's may already be
    ``position``); 1 when none is named.

    Examples
    --------
    >>> arm_count(["position", "robot1_eef_pos", "pot_pos"])
    2
    >>> arm_count(["position", "cube_pos"])
    1
    """
    names = set(streams)
    k = 1
    while f"robot{k}_eef_pos" in names:
        k += 1
    return k


def arm_of(metadata) -> int | None:
    """Which arm of a recording of several a demonstration's ``metadata`` says it is of (``arm_index``, with
    ``arms`` above 1, as :func:`split_arms` writes them); None for one arm's, or where it says nothing
    usable.

    Examples
    --------
    >>> arm_of({"arm_index": 1, "arms": 2}), arm_of({"arm": "Panda"}), arm_of({"arm_index": "1", "arms": 2})
    (1, None, None)
    """
    index, arms = metadata.get(ARM_INDEX), metadata.get("arms")
    if not all(isinstance(v, int) and not isinstance(v, bool) for v in (index, arms)) or arms < 2:
        return None
    return index


def split_arms(demo: Demonstration, *, robots=None, pose_of=None) -> list[Demonstration]:
    """The recording ``demo`` as one demonstration per arm (itself alone when it has one arm).

    Parameters
    ----------
    demo : Demonstration
        Arm 0's tool pose and gripper under skillbank's names (as the readers rename them) or as
        ``robot0_eef_pos`` ...; the other arms' as ``robotK_eef_pos``, ``robotK_eef_quat``,
        ``robotK_gripper_qpos``; ``actions`` the arms' actions side by side, an equal number of columns
        each.
    robots : list of str, optional
        The recorded arms, by index (robosuite's names): each demonstration's ``metadata["arm"]``.
    pose_of : list of str, optional
        The point of each arm its poses are of: each demonstration's ``metadata["pose_of"]``.

    Returns
    -------
    list of Demonstration
        Arm K's: its tool pose and gripper as ``position``, ``orientation``, ``gripper``; its other
        ``robotK_*`` streams as recorded; the streams of no arm (the objects' poses) shared; its columns
        of ``actions``. Metadata as ``demo``'s, with ``arm_index``, ``arms`` and ``label`` ending
        ``" arm K"``.

    Raises
    ------
    ValueError
        An arm without its tool's orientation, or actions that do not split evenly among the arms.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(3.0)
    >>> q = np.tile([0.0, 0.0, 0.0, 1.0], (3, 1))
    >>> two = Demonstration(t, {"position": np.zeros((3, 3)), "orientation": q,
    ...                         "robot1_eef_pos": np.ones((3, 3)), "robot1_eef_quat": q,
    ...                         "pot_pos": np.zeros((3, 3)), "actions": np.zeros((3, 14))})
    >>> [(d.metadata["arm_index"], d["position"][0, 0], d["actions"].shape[1]) for d in split_arms(two)]
    [(0, 0.0, 7), (1, 1.0, 7)]
    """
    n = arm_count(demo.streams)
    if n == 1:
        return [demo]
    width = None
    if "actions" in demo.streams:
        cols = demo["actions"].shape[1]
        if cols % n:
            raise ValueError(f"actions: {cols} columns do not split among the recording's {n} arms; "
                             "expected each arm's actions side by side, as robosuite concatenates them")
        width = cols // n
    out = []
    for k in range(n):
        prefix = f"robot{k}_"
        streams = {}
        for stream, suffix in ARM_STREAMS:
            key = prefix + suffix
            if k == 0 and stream in demo.streams:
                streams[stream] = demo[stream]
            elif key in demo.streams:
                streams[stream] = demo[key]
            elif stream != "gripper":
                raise ValueError(f"arm {k}: the recording has no {key}; each arm's tool pose is needed")
        for name, values in demo.streams.items():
            m = _ROBOT.match(name)
            if name in ("position", "orientation", "gripper", "actions"):
                continue
            if m is None:
                streams[name] = values  # an object's pose: every arm's scene
            elif int(m.group(1)) == k and name[len(prefix):] not in dict(ARM_STREAMS).values():
                streams[name] = values
        if width is not None:
            streams["actions"] = demo["actions"][:, k * width:(k + 1) * width]
        meta = dict(demo.metadata)
        meta[ARM_INDEX], meta["arms"] = k, n
        if meta.get("label") is not None:
            meta["label"] = f"{meta['label']} arm {k}"
        if robots is not None and k < len(robots):
            meta["arm"] = robots[k]
        if pose_of is not None and k < len(pose_of) and pose_of[k] is not None:
            meta[POSE_OF] = pose_of[k]
        out.append(Demonstration(demo.t, streams, meta))
    return out
