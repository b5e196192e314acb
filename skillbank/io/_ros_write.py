"""Small ROS bags written message by message with rosbags' own writers: the example recordings
(``examples/make_examples.py``) and the inputs of the reader's tests.

A recording is ``{topic: (msgtype, [(stamp_ns, log_ns, value), ...])}``: each message's header stamp,
the time the recorder logged it, and its numbers (:func:`message`). :func:`write_bag` writes it as a
ROS 1 bag, a ROS 2 bag (sqlite3 or MCAP) or a plain MCAP file, the ways the reader
(:func:`skillbank.io.read_rosbag`) meets them. Not the export: a planned trajectory is written by
``_trajectory_export``.

``rosbags`` is the optional extra ``ros``, imported when a bag is written.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np

__all__ = ["STORAGES", "typestore", "header", "message", "write_bag"]

#: How :func:`write_bag` stores a recording.
STORAGES = ("ros1", "sqlite3", "mcap", "plain-mcap")
NS = 1_000_000_000


def _missing_rosbags():
    return ImportError("writing ROS bags needs the 'rosbags' package: pip install skillbank[ros]")


def typestore(ros1: bool, extra=None):
    """rosbags' standard types of ROS 1 (Noetic) or ROS 2 (the latest), with ``extra`` registered.

    Parameters
    ----------
    ros1 : bool
    extra : mapping of str to str, optional
        ``{msgtype: message definition}`` of types the store may lack (registered only where it does);
        their definitions travel in the bag.

    Returns
    -------
    rosbags.typesys.store.Typestore
    """
    try:
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore  # optional extra skillbank[ros]
    except ImportError:
        raise _missing_rosbags() from None
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.LATEST)
    types = {}
    for name, text in (extra or {}).items():
        if name not in store.types:
            types.update(get_types_from_msg(text, name))
    store.register(types)
    return store


def header(ts, ns: int, frame: str = ""):
    """A ``std_msgs/Header`` stamped ``ns`` (epoch nanoseconds), with ROS 1's ``seq`` where it has one."""
    cls, time = ts.types["std_msgs/msg/Header"], ts.types["builtin_interfaces/msg/Time"]
    stamp = time(sec=int(ns // NS), nanosec=int(ns % NS))
    if "seq" in cls.__dataclass_fields__:  # ROS 1
        return cls(seq=0, stamp=stamp, frame_id=frame)
    return cls(stamp=stamp, frame_id=frame)


def message(ts, msgtype: str, ns: int, value):
    """A message of ``msgtype`` stamped ``ns`` carrying ``value``.

    ``sensor_msgs/msg/JointState``: ``(names, positions)``; ``geometry_msgs/msg/PoseStamped``:
    ``(xyz, (x, y, z, w))`` in frame ``base``; ``geometry_msgs/msg/WrenchStamped``: ``(force, torque)`` in
    frame ``tool0``.

    Raises
    ------
    ValueError
        Another ``msgtype``.
    """
    cls = ts.types[msgtype]
    vector = ts.types["geometry_msgs/msg/Vector3"]
    if msgtype == "sensor_msgs/msg/JointState":
        names, position = value
        empty = np.array([], dtype=float)
        return cls(header=header(ts, ns), name=list(names), position=np.asarray(position, dtype=float),
                   velocity=empty, effort=empty)
    if msgtype == "geometry_msgs/msg/PoseStamped":
        xyz, q = value
        point, quat = ts.types["geometry_msgs/msg/Point"], ts.types["geometry_msgs/msg/Quaternion"]
        pose = ts.types["geometry_msgs/msg/Pose"](position=point(*map(float, xyz)),
                                                  orientation=quat(*map(float, q)))
        return cls(header=header(ts, ns, "base"), pose=pose)
    if msgtype == "geometry_msgs/msg/WrenchStamped":
        force, torque = value
        wrench = ts.types["geometry_msgs/msg/Wrench"](force=vector(*map(float, force)),
                                                      torque=vector(*map(float, torque)))
        return cls(header=header(ts, ns, "tool0"), wrench=wrench)
    raise ValueError(f"msgtype: expected one of JointState, PoseStamped, WrenchStamped, got {msgtype!r}")


def write_bag(path, storage: str, recording: dict, *, ts=None, build=message) -> Path:
    """Write ``recording`` to ``path`` with rosbags' own writer, in log-time order.

    Parameters
    ----------
    path : path-like
        What is written: the ``.bag`` file (``"ros1"``), the bag's folder (``"sqlite3"``, ``"mcap"``) or
        the ``.mcap`` file (``"plain-mcap"``: a ROS 2 bag written beside it, without its suffix, and all
        but the file removed).
    storage : {"ros1", "sqlite3", "mcap", "plain-mcap"}
    recording : dict
        ``{topic: (msgtype, [(stamp_ns, log_ns, value), ...])}``.
    ts : Typestore, optional
        Of the bag's ROS version (default :func:`typestore`'s).
    build : callable, default=message
        ``build(ts, msgtype, stamp_ns, value)``: the message (other types than :func:`message` knows).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ImportError
        ``rosbags`` is not installed (one line naming the extra).
    """
    if storage not in STORAGES:
        raise ValueError(f"storage: expected one of {list(STORAGES)}, got {storage!r}")
    try:
        from rosbags.rosbag1 import Writer as Ros1Writer  # optional extra skillbank[ros]
        from rosbags.rosbag2 import StoragePlugin
        from rosbags.rosbag2 import Writer as Ros2Writer
    except ImportError:
        raise _missing_rosbags() from None
    path = Path(path)
    ros1 = storage == "ros1"
    ts = typestore(ros1) if ts is None else ts
    folder = path.with_suffix("") if storage == "plain-mcap" else path
    if ros1:
        writer = Ros1Writer(path)
    else:
        plugin = StoragePlugin.SQLITE3 if storage == "sqlite3" else StoragePlugin.MCAP
        writer = Ros2Writer(folder, version=9, storage_plugin=plugin)
    messages = sorted((log, topic, msgtype, stamp, value)
                      for topic, (msgtype, items) in recording.items() for stamp, log, value in items)
    serialise = ts.serialize_ros1 if ros1 else ts.serialize_cdr
    with writer:
        conns = {topic: writer.add_connection(topic, msgtype, typestore=ts)
                 for topic, (msgtype, _) in recording.items()}
        for log, topic, msgtype, stamp, value in messages:
            writer.write(conns[topic], log, serialise(build(ts, msgtype, stamp, value), msgtype))
    if storage == "plain-mcap":  # the MCAP file alone, as a plain MCAP recorder leaves it
        shutil.move(str(next(folder.glob("*.mcap"))), path)
        shutil.rmtree(folder)
    return path
