"""ROS messages: the types skillbank maps, how their numbers are taken out, which topic makes which stream.

Decoded messages (``rosbags``' classes) go into :class:`Samples`, one per
topic, that keeps only the stamps and the numbers, in arrays that grow.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Mapping

import numpy as np

from ..core._validation import summarise
from ._errors import FormatError

__all__ = ["ROLES", "MESSAGE_TYPES", "DISCRETE_TYPES", "Samples", "parse_topics", "default_topics",
           "check_mapping", "header_ns", "frame_id"]

#: Stream roles a topic can be mapped to, and the streams each makes; any other name makes one stream.
ROLES = {"joints": ("joints",), "pose": ("position", "orientation"), "wrench": ("force", "torque"),
         "gripper": ("gripper",)}

#: Message type -> (family, has a header). The family says how the numbers are taken out.
MESSAGE_TYPES = {
    "sensor_msgs/msg/JointState": ("joint_state", True),
    "geometry_msgs/msg/PoseStamped": ("pose", True),
    "geometry_msgs/msg/PoseWithCovarianceStamped": ("pose", True),
    "geometry_msgs/msg/Pose": ("pose", False),
    "geometry_msgs/msg/TransformStamped": ("transform", True),
    "tf2_msgs/msg/TFMessage": ("tf", True),
    "geometry_msgs/msg/WrenchStamped": ("wrench", True),
    "geometry_msgs/msg/Wrench": ("wrench", False),
    "geometry_msgs/msg/TwistStamped": ("twist", True),
    "geometry_msgs/msg/Vector3Stamped": ("vector", True),
    "geometry_msgs/msg/PointStamped": ("vector", True),
    "control_msgs/msg/GripperCommand": ("gripper_command", False),
    "control_msgs/msg/GripperCommandGoal": ("gripper_command", False),
    "control_msgs/msg/GripperCommandActionGoal": ("gripper_command", True),
    **{f"std_msgs/msg/{kind}": ("scalar", False) for kind in ("Float64", "Float32", "Int8", "Int16", "Int32",
                                                               "Int64", "UInt8", "UInt16", "UInt32", "UInt64",
                                                               "Bool")},
    "std_msgs/msg/Float64MultiArray": ("array", False),
    "std_msgs/msg/Float32MultiArray": ("array", False),
}
# Which families each role accepts (any other stream name accepts every family).
_ROLE_FAMILIES = {"joints": ("joint_state",), "pose": ("pose", "transform", "tf"), "wrench": ("wrench",),
                  "gripper": ("joint_state", "gripper_command", "scalar")}
DISCRETE_TYPES = {f"std_msgs/msg/{k}" for k in ("Bool", "Int8", "Int16", "Int32", "Int64", "UInt8", "UInt16",
                                                  "UInt32", "UInt64")}
_GROW_FROM = 1024  # samples; arrays double when full
_NS = 1_000_000_000


# ---------------------------------------------------------------- collecting one topic's samples


class Samples:
    """One topic's stamps (int ns) and numbers, in arrays that double when full."""

    def __init__(self, path, topic: str, msgtype: str, frames):
        self.path, self.topic, self.msgtype = path, topic, msgtype
        self.family, self.stamped = MESSAGE_TYPES[msgtype]
        self.parent, self.child = frames
        self.stamps = np.empty(_GROW_FROM, dtype=np.int64)
        self.rows = None
        self.n = 0
        self.from_log = 0  # messages whose stamp was zero, timed by their log time instead
        self.names = None  # joint names, in column order
        self.pairs = set()  # (parent, child) frames seen on a transform topic
        self.skipped = 0  # transforms between other frames
        self.add = getattr(self, f"_add_{self.family}")

    def _push(self, stamp, log_ns: int, row) -> None:
        if stamp == 0:
            stamp = log_ns
            self.from_log += 1
        if self.rows is None:
            self.rows = np.empty((_GROW_FROM, len(row)), dtype=float)
        elif len(row) != self.rows.shape[1]:
            raise FormatError(self.path, f"topic {self.topic!r}: expected {self.rows.shape[1]} values per "
                              f"message, message {self.n + self.skipped} has {len(row)}")
        elif self.n == self.stamps.shape[0]:
            self.stamps = np.concatenate([self.stamps, np.empty_like(self.stamps)])
            self.rows = np.concatenate([self.rows, np.empty_like(self.rows)])
        self.stamps[self.n] = stamp
        self.rows[self.n] = row
        self.n += 1

    def _add_joint_state(self, msg, log_ns):
        names, position = msg.name, msg.position
        if names and names != self.names:
            self._check_distinct(names)
        if self.names is None:
            self.names = list(names) if names else [str(i) for i in range(len(position))]
        elif names != self.names and names:  # JointState does not promise an order: go by name
            try:
                position = np.asarray(position)[[names.index(name) for name in self.names]]
            except (ValueError, IndexError):
                raise FormatError(self.path, f"topic {self.topic!r}: message {self.n} names joints {names}, "
                                  f"expected the first message's {self.names}") from None
        if len(position) != len(self.names):
            raise FormatError(self.path, f"topic {self.topic!r}: expected {len(self.names)} joint positions, "
                              f"message {self.n} has {len(position)}")
        self._push(header_ns(msg.header), log_ns, position)

    def _check_distinct(self, names) -> None:
        # Columns are matched by name: a name given twice leaves one of its positions unread.
        twice = sorted(n for n, count in Counter(names).items() if count > 1)
        if twice:
            raise FormatError(self.path, f"topic {self.topic!r}: message {self.n + self.skipped} names "
                              f"joint(s) {summarise(map(repr, twice))} more than once; expected distinct "
                              "joint names, one per position")

    def _add_pose(self, msg, log_ns):
        pose = msg.pose if self.stamped else msg
        pose = getattr(pose, "pose", pose)  # PoseWithCovarianceStamped nests one level deeper
        p, q = pose.position, pose.orientation
        self._push(header_ns(msg.header) if self.stamped else 0, log_ns, (p.x, p.y, p.z, q.x, q.y, q.z, q.w))

    def _add_transform(self, msg, log_ns):
        pair = (frame_id(msg.header.frame_id), frame_id(msg.child_frame_id))
        self.pairs.add(pair)
        if self.child is not None and pair != (self.parent, self.child):
            self.skipped += 1
            return
        tr, q = msg.transform.translation, msg.transform.rotation
        self._push(header_ns(msg.header), log_ns, (tr.x, tr.y, tr.z, q.x, q.y, q.z, q.w))

    def _add_tf(self, msg, log_ns):
        for transform in msg.transforms:
            self._add_transform(transform, log_ns)

    def _add_wrench(self, msg, log_ns):
        w = msg.wrench if self.stamped else msg
        self._push(header_ns(msg.header) if self.stamped else 0, log_ns,
                   (w.force.x, w.force.y, w.force.z, w.torque.x, w.torque.y, w.torque.z))

    def _add_twist(self, msg, log_ns):
        lin, ang = msg.twist.linear, msg.twist.angular
        self._push(header_ns(msg.header), log_ns, (lin.x, lin.y, lin.z, ang.x, ang.y, ang.z))

    def _add_vector(self, msg, log_ns):
        v = msg.vector if hasattr(msg, "vector") else msg.point
        self._push(header_ns(msg.header), log_ns, (v.x, v.y, v.z))

    def _add_gripper_command(self, msg, log_ns):
        command = msg.goal.command if hasattr(msg, "goal") else getattr(msg, "command", msg)
        self._push(header_ns(msg.header) if self.stamped else 0, log_ns, (command.position,))

    def _add_scalar(self, msg, log_ns):
        self._push(0, log_ns, (float(msg.data),))

    def _add_array(self, msg, log_ns):
        self._push(0, log_ns, msg.data)

    def take(self, origin: int, columns=None) -> tuple[np.ndarray, np.ndarray]:
        """Seconds since ``origin`` (ns; subtracted as integers, so no precision is lost) and the rows.

        Only ``columns`` (default all) are kept, in that order, and the
        growing buffers are let go: the rows are copied to their own size.
        """
        t = (self.stamps[:self.n] - origin) / 1e9
        rows = self.rows[:self.n].copy() if columns is None else self.rows[:self.n, list(columns)]
        self.stamps, self.rows = np.empty(0, dtype=np.int64), np.empty((0, rows.shape[1]))
        return t, rows


def header_ns(header) -> int:
    return header.stamp.sec * _NS + header.stamp.nanosec


def frame_id(name: str) -> str:
    return name.lstrip("/")  # ROS 1 frame ids may carry a leading slash


# ---------------------------------------------------------------- which topic makes which stream


def parse_topics(topics) -> dict[str, str]:
    """``{topic: stream}`` from a mapping, or from ``"topic=stream"`` strings (the command line's form).

    Examples
    --------
    >>> parse_topics(["/joint_states=joints", "/ft=wrench"])
    {'/joint_states': 'joints', '/ft': 'wrench'}
    """
    if isinstance(topics, str) or not isinstance(topics, (Mapping, Iterable)):
        raise ValueError(f"topics: expected a mapping of topic to stream name or 'topic=stream' strings, "
                         f"got {topics!r}")
    if not isinstance(topics, Mapping):
        pairs = []
        for item in topics:
            topic, sep, name = str(item).partition("=") if isinstance(item, str) else ("", "", "")
            if not sep:
                raise ValueError(f"topics: expected 'topic=stream' like '/joint_states=joints', got {item!r}")
            pairs.append((topic.strip(), name.strip()))
        topics = dict(pairs)
    out = {}
    for topic, name in topics.items():
        if not isinstance(topic, str) or not topic or not isinstance(name, str) or not name:
            raise ValueError(f"topics: expected non-empty topic and stream names, got {topic!r}: {name!r}")
        out[topic] = name
    if not out:
        raise ValueError("topics: expected at least one topic, got none")
    made = [s for name in out.values() for s in ROLES.get(name, (name,))]
    twice = sorted({s for s in made if made.count(s) > 1})
    if twice:
        raise ValueError(f"topics: expected each stream from one topic, got {twice} from several")
    return out


def default_topics(path, found: dict, frames) -> tuple[dict, dict]:
    """The default mapping by message type; returns (mapping, skipped topics with their types)."""
    candidates, skipped = {}, {}
    for topic, msgtype in sorted(found.items()):
        family = MESSAGE_TYPES.get(msgtype, (None,))[0]
        role = None
        if family == "joint_state":
            role = "gripper" if "gripper" in topic.lower() else "joints"
        elif family in ("pose", "transform") and frames[1] is None:
            role = "pose"
        elif family in ("tf", "transform") and frames[1] is not None and not topic.endswith("tf_static"):
            role = "pose"  # frames were named: the pose comes from the transforms
        elif family == "wrench":
            role = "wrench"
        elif family == "gripper_command":
            role = "gripper"
        if role is None:
            skipped[topic] = msgtype
        else:
            candidates.setdefault(role, []).append(topic)
    for role, names in candidates.items():
        if len(names) > 1:
            raise FormatError(path, f"several topics could give {role!r} ({', '.join(names)}): choose one "
                              f"with topics={{'{names[0]}': '{role}', ...}}")
    if not candidates:
        listed = summarise([f"{t} ({m})" for t, m in sorted(found.items())])
        raise FormatError(path, f"no topic has a default mapping (found {listed or 'no topics'}): map topics "
                          "by hand with topics={'/joint_states': 'joints', ...}")
    return {names[0]: role for role, names in candidates.items()}, skipped


def check_mapping(path, mapping: dict, found: dict, frames) -> None:
    for topic, name in mapping.items():
        if topic not in found:
            raise FormatError(path, f"topic {topic!r} is not in the bag; its topics are "
                              f"[{summarise(map(repr, sorted(found)))}]")
        family = MESSAGE_TYPES.get(found[topic], (None,))[0]
        allowed = _ROLE_FAMILIES.get(name)
        if family is None or (allowed is not None and family not in allowed):
            types = sorted(m for m, (f, _) in MESSAGE_TYPES.items() if allowed is None or f in allowed)
            raise FormatError(path, f"topic {topic!r} has message type {found[topic]!r}, which has no "
                              f"mapping to stream {name!r}: expected one of [{summarise(types, limit=6)}]")
        if family == "tf" and frames[1] is None:
            raise FormatError(path, f"topic {topic!r} holds transforms between many frames: name the pose "
                              "with parent_frame and child_frame")
