"""Reader for ROS 1 bags, ROS 2 bags (sqlite3 or MCAP storage) and plain MCAP files, without ROS.

Messages are decoded by the pure-Python ``rosbags`` package (the optional
extra ``skillbank[ros]``) one at a time, and only the numbers a stream needs
are kept, in growing arrays, so a bag of any size is read in memory
proportional to those numbers. Each topic keeps its own clock until
:mod:`._align` brings the streams onto one time base.
"""

from __future__ import annotations

from contextlib import ExitStack, contextmanager
from pathlib import Path

import numpy as np
from tqdm import tqdm

from ..core import Demonstration
from ..core._validation import check_positive, summarise
from ._align import Source, align_sources, check_split, split_pieces, time_base
from ._confine import check_input_folder
from ._errors import (
    FormatError,
    as_file,
    check_clock,
    check_repair_time,
    describe_content,
    read_head,
    reading,
)
from ._robot_h5 import UR_JOINT_NAMES
from ._ros_messages import (
    DISCRETE_TYPES,
    ROLES,
    Samples,
    check_mapping,
    default_topics,
    frame_id,
    header_ns,
    parse_topics,
)

__all__ = ["read_rosbag", "ROS_FILES", "ROS2_METADATA", "ros_kind"]

#: Bag files by suffix: (format name, the bytes they start with).
ROS_FILES = {
    ".bag": ("ros1-bag", b"#ROSBAG V2.0\n"),
    ".mcap": ("mcap", b"\x89MCAP0\r\n"),
    ".db3": ("ros2-bag", b"SQLite format 3\x00"),
}
#: A ROS 2 bag is a folder holding this file.
ROS2_METADATA = "metadata.yaml"


def _missing_rosbags():
    return ImportError("reading ROS bags and MCAP files needs the 'rosbags' package: "
                       "pip install skillbank[ros]")


def ros_kind(path) -> str:
    """The format of a bag path (``ros1-bag``, ``ros2-bag`` or ``mcap``), checked against its content.

    Examples
    --------
    >>> ros_kind("recording.bag")  # doctest: +SKIP
    'ros1-bag'
    """
    p = Path(path)
    if not p.exists():
        raise FormatError(p, "no such file or folder")
    if p.is_dir():
        if not (p / ROS2_METADATA).is_file():
            raise FormatError(p, f"expected a ROS 2 bag folder holding {ROS2_METADATA}, found a folder "
                              "without it")
        # rosbags opens the storage files the metadata names, in this folder: each must be a regular file
        # (a FIFO would block), and no link may lead out of the folder.
        check_input_folder(p, what="a ROS 2 bag folder")
        return "ros2-bag"
    as_file(p)
    if p.suffix.lower() not in ROS_FILES:
        raise FormatError(p, f"expected a ROS bag ({', '.join(ROS_FILES)} or a ROS 2 bag folder), "
                          f"found extension {p.suffix or '(none)'!r}")
    kind, magic = ROS_FILES[p.suffix.lower()]
    head = read_head(p)
    if not head.startswith(magic):
        raise FormatError(p, f"expected a {kind} file, found {describe_content(head)}")
    return kind


@contextmanager
def _bag_errors(path):
    """rosbags' own errors (and sqlite's, for .db3) as one-line FormatErrors."""
    from rosbags.highlevel import AnyReaderError  # optional extra, imported with the reader
    from rosbags.rosbag1 import ReaderError as Ros1Error
    from rosbags.rosbag2 import ReaderError as Ros2Error
    from rosbags.serde import SerdeError
    from rosbags.typesys import TypesysError

    errors = (AnyReaderError, Ros1Error, Ros2Error, SerdeError, TypesysError)
    try:
        import apsw  # rosbags' sqlite binding; a truncated .db3 fails inside it

        errors += (apsw.Error,)
    except ImportError:  # pragma: no cover - rosbags depends on it
        pass
    try:
        with reading(path, "unreadable ROS bag"):
            yield
    except errors as exc:
        detail = " ".join(str(exc).split()) or type(exc).__name__
        raise FormatError(path, f"unreadable ROS bag: {detail}") from None
    except AssertionError:  # rosbags checks a ROS 1 bag's records against each other with assert
        raise FormatError(path, "unreadable ROS bag: its records contradict each other (a consistency check "
                          "of the reader failed), so the file is corrupt; 'rosbag reindex' may repair a "
                          "copy of it") from None
    except MemoryError:  # a record's length field claims more than memory holds: read it, not trust it
        raise FormatError(path, "unreadable ROS bag: a record claims more bytes than this machine can hold, "
                          "far more than the file has, so the file is corrupt") from None


def _open(p, stack):
    """Open the bag (closed with ``stack``): the reader and ``{topic: (type, message count)}``."""
    from rosbags.highlevel import AnyReader  # optional extra (skillbank[ros])
    from rosbags.typesys import Stores, get_typestore

    # Bags that carry no message definitions (old ROS 2 sqlite3 bags) are decoded with the standard types.
    reader = stack.enter_context(AnyReader([p], default_typestore=get_typestore(Stores.LATEST)))
    return reader, {name: (info.msgtype, info.msgcount) for name, info in reader.topics.items()}


def _stream(p, reader, mapping, found, frames, marker, progress):
    """Read the bag once: (samples by topic, marker (times ns, Bool values or None))."""
    samples = {topic: Samples(p, topic, found[topic], frames) for topic in mapping}
    is_bool = marker is not None and found[marker] == "std_msgs/msg/Bool"
    marks, values = [], []
    conns = [c for c in reader.connections if c.topic in samples or c.topic == marker]
    step = 4096  # messages per progress-bar update: a per-message update costs more than decoding
    with tqdm(total=sum(c.msgcount for c in conns), desc="reading bag", unit="msg", unit_scale=True,
              disable=not progress, leave=False) as bar:
        for k, (conn, log_ns, raw) in enumerate(reader.messages(connections=conns), 1):
            msg = reader.deserialize(raw, conn.msgtype)
            if conn.topic in samples:
                samples[conn.topic].add(msg, log_ns)
            if conn.topic == marker:
                header = getattr(msg, "header", None)
                marks.append((header_ns(header) if header is not None else 0) or log_ns)
                values.append(bool(msg.data) if is_bool else None)
            if k % step == 0:
                bar.update(step)
    return samples, (np.asarray(marks, dtype=np.int64), np.asarray(values, dtype=bool) if is_bool else None)


def _reference(reference, mapping: dict, counts: dict) -> str:
    if reference is None:
        joints = [t for t, name in mapping.items() if name == "joints"]
        return joints[0] if joints else max(mapping, key=counts.get)
    if reference in mapping:
        return reference
    for topic, name in mapping.items():
        if reference == name or reference in ROLES.get(name, ()):
            return topic
    options = list(mapping) + sorted({s for n in mapping.values() for s in ROLES.get(n, (n,))})
    raise ValueError(f"reference: expected a read topic or stream among {options}, got {reference!r}")


def _check_hold(hold, mapping: dict):
    if hold is None:
        return None
    hold = [hold] if isinstance(hold, str) else list(hold)
    held_roles = [n for n in mapping.values() if n not in ("pose", "wrench")]
    if not all(isinstance(n, str) and n in held_roles for n in hold):
        raise ValueError(f"hold: expected names among the read streams {held_roles}, got {hold!r}")
    return hold


def _clock_kind(s: Samples) -> str:
    if not s.stamped or s.from_log == s.n:
        return "log"
    return "header" if s.from_log == 0 else "header+log"


def read_rosbag(path, *, topics=None, reference=None, rate=None, max_gap=0.5, on_gap="error",
                parent_frame=None, child_frame=None, joint_names=None, hold=None, split=None,
                repair_time=None, progress=False) -> list[Demonstration]:
    """Read a ROS 1 bag, a ROS 2 bag (sqlite3 or MCAP storage) or a plain MCAP file, without ROS.

    Needs the optional extra ``skillbank[ros]`` (the pure-Python ``rosbags``).
    Messages are streamed: only the numbers of the read topics are kept.

    Each topic keeps its own clock: the header stamp, or the log (receive)
    time for a message whose stamp is zero or that has no header. All
    streams are then brought onto one time base, the reference topic's clock
    (or ``rate`` Hz across its span): measured values linearly (a gripper's
    ``JointState`` too: its fingers move continuously), orientations by
    SLERP, discrete values held (gripper commands, integer and boolean
    messages: they change in steps). Outside its own time range a stream
    holds its edge value; the report says how far that reaches.

    Parameters
    ----------
    path : str or path-like
        A ``.bag`` file (ROS 1), a ROS 2 bag folder (``metadata.yaml`` with
        ``.db3`` or ``.mcap`` files), or a ``.mcap`` or ``.db3`` file.
    topics : mapping or list of str, optional
        Which topic makes which stream: ``{"/joint_states": "joints",
        "/tool_pose": "pose", "/ft": "wrench", "/gripper": "gripper"}`` or
        ``["/joint_states=joints", ...]``. ``joints`` takes a
        ``sensor_msgs/JointState``; ``pose`` (streams ``position`` and
        ``orientation``, a quaternion ``x, y, z, w``) a ``PoseStamped``,
        ``PoseWithCovarianceStamped``, ``TransformStamped`` or
        ``tf2_msgs/TFMessage``; ``wrench`` (``force`` and ``torque``) a ``WrenchStamped``; ``gripper``
        a ``JointState``, a ``control_msgs`` gripper command or a ``std_msgs``
        number; any other name makes one stream of that name from any type
        in ``MESSAGE_TYPES``. By default each topic of a known type is
        mapped: a ``JointState`` to ``joints`` (to ``gripper`` when its topic
        name holds "gripper"), a pose or transform to ``pose`` (with frames
        named: the ``/tf`` transform between them), a wrench to ``wrench``, a
        gripper command to ``gripper``; other topics are listed in
        ``metadata["skipped_topics"]``.
    reference : str, optional
        The topic (or stream) whose clock is the time base; default the
        ``joints`` topic, else the topic with most messages.
    rate : float, optional
        Resample onto ``rate`` Hz across the reference's span instead.
    max_gap : float, default=0.5
        Seconds. A stamped topic with a longer interval without a message
        inside a demonstration (its start and end included) is an error
        (see ``on_gap``). Topics without a header (commands, ``std_msgs``)
        publish when something changes: their gaps are reported, never
        rejected.
    on_gap : {"error", "warn"}, default="error"
        ``"warn"`` turns the gap error into a ``UserWarning``.
    parent_frame, child_frame : str, optional
        The transform to read as ``pose`` from ``/tf`` or a
        ``TransformStamped`` topic (only the direct transform: chains of
        transforms are not composed).
    joint_names : list of str, optional
        Keep these joints of the ``joints`` topic, in this order (for
        example the kinematic chain's). By default the joints keep the first
        message's order, except a UR arm's six joints, which a UR driver
        publishes alphabetically: they are put in chain order, as
        :func:`~skillbank.io.read_robot_h5` does.
    hold : list of str, optional
        Streams to hold (zero-order) instead of interpolating, for example
        ``["gripper"]`` for a gripper that reports only open or closed.
        Default: by message type, as above.
    split : None, "gaps", str or list of (float, float), optional
        Cut the bag into several demonstrations: ``"gaps"`` where the
        reference topic pauses for more than ``max_gap``; a marker topic
        (``"/marker"``), where each message starts a demonstration (a
        ``std_msgs/Bool`` marker starts one with True and ends it with
        False; anything before the first marker is dropped); or
        ``[(start, stop), ...]`` in seconds from the reference topic's first
        sample, each half-open. Automatic pieces with fewer than 2 reference
        samples are dropped.
    repair_time : {None, "drop"}, default=None
        A topic whose stamps repeat or run backwards is an error naming it;
        ``"drop"`` drops repeated stamps (see :func:`~skillbank.io.load_all`).
    progress : bool, default=False
        A tqdm bar over the messages.

    Returns
    -------
    list of Demonstration
        One per piece (one without ``split``). ``t`` starts at 0. Metadata:
        ``source``, ``format`` (``"ros1-bag"``, ``"ros2-bag"`` or
        ``"mcap"``), ``t0`` (the absolute start, seconds), ``reference``,
        ``streams`` (stream -> topic), ``joint_names`` (the ``joints``
        columns), ``column_names`` (the joint names of other ``JointState``
        streams), ``topics`` (per topic: ``stream``, ``type``,
        ``clock`` (``"header"``, ``"log"`` or ``"header+log"``), ``held``,
        ``gaps_checked``, and :func:`coverage`'s ``messages``, ``rate_hz``,
        ``start``, ``end``, ``max_gap``, ``n_gaps``, ``gaps``), with
        ``rate_hz`` when resampled, ``index`` and ``split`` (``[from, to]``
        seconds) when split, ``skipped_topics`` and ``dropped_samples``.

    Raises
    ------
    ImportError
        Without ``rosbags``: ``pip install skillbank[ros]``.
    FormatError
        An unreadable or truncated bag, a topic that is not there, a message
        type with no mapping, ambiguous defaults, a topic without messages,
        or a gap longer than ``max_gap``.
    ValueError
        A bad option.

    Examples
    --------
    >>> demo, = read_rosbag("run.bag", topics={"/joint_states": "joints", "/ft": "wrench"})  # doctest: +SKIP
    >>> demo.stream_names, demo.metadata["topics"]["/ft"]["rate_hz"]  # doctest: +SKIP
    (['joints', 'force', 'torque'], 100.0)
    """
    mapping = None if topics is None else parse_topics(topics)
    rate = None if rate is None else check_positive(rate, name="rate")
    max_gap = check_positive(max_gap, name="max_gap")
    if on_gap not in ("error", "warn"):
        raise ValueError(f"on_gap: expected 'error' or 'warn', got {on_gap!r}")
    if (parent_frame is None) != (child_frame is None):
        raise ValueError(f"parent_frame, child_frame: expected both or neither, got {parent_frame!r} and "
                         f"{child_frame!r}")
    frames = (None, None) if child_frame is None else (frame_id(str(parent_frame)),
                                                       frame_id(str(child_frame)))
    if joint_names is not None and (isinstance(joint_names, str) or not all(
            isinstance(n, str) and n for n in joint_names) or not list(joint_names)):
        raise ValueError(f"joint_names: expected a list of joint names, got {joint_names!r}")
    split = check_split(split)
    check_repair_time(repair_time)
    try:
        import rosbags.highlevel  # noqa: F401  optional extra; fail early with the install line
    except ImportError:
        raise _missing_rosbags() from None
    fmt = ros_kind(path)
    p = Path(path)
    marker = split if isinstance(split, str) and split != "gaps" else None
    with ExitStack() as stack:
        with _bag_errors(p):
            reader, topics_found = _open(p, stack)
        found = {topic: msgtype for topic, (msgtype, _) in topics_found.items()}
        skipped = {}
        if mapping is None:
            mapping, skipped = default_topics(p, found, frames)
        else:
            check_mapping(p, mapping, found, frames)
        if marker is not None and marker not in found:
            raise FormatError(p, f"marker topic {marker!r} is not in the bag; its topics are "
                              f"[{summarise(map(repr, sorted(found)))}]")
        # The options that depend on the mapping are checked before the (long) read.
        ref_topic = _reference(reference, mapping, {t: c for t, (_, c) in topics_found.items()})
        hold = _check_hold(hold, mapping)
        with _bag_errors(p):
            samples, marks = _stream(p, reader, mapping, found, frames, marker, progress)
    for topic, s in samples.items():
        pairs = summarise(sorted(f"{a}->{b}" for a, b in s.pairs))
        if s.n == 0 and s.pairs:
            raise FormatError(p, f"no transform from {frames[0]!r} to {frames[1]!r} on {topic!r}; it holds "
                              f"[{pairs}]")
        if s.n == 0:
            raise FormatError(p, f"topic {topic!r} holds no messages")
        if frames[1] is None and len(s.pairs) > 1:
            raise FormatError(p, f"topic {topic!r} holds transforms between several frames [{pairs}]: name "
                              "one with parent_frame and child_frame")
    origin = int(min(s.stamps[:s.n].min() for s in samples.values()))
    sources, names, dropped = _sources(p, mapping, samples, origin, joint_names, repair_time, ref_topic, hold)
    t_ref = sources[ref_topic].t
    marker_times = None if marker is None else ((marks[0] - origin) / 1e9, marks[1])
    common = {"source": str(p), "format": fmt, "reference": ref_topic}
    if "joints" in names:
        common["joint_names"] = names.pop("joints")
    for key, value in (("rate_hz", rate), ("column_names", names), ("skipped_topics", skipped),
                       ("dropped_samples", dropped)):
        if value:
            common[key] = value
    demos = []
    for k, (lo, hi) in enumerate(split_pieces(split, t_ref, marker_times, max_gap)):
        inside = t_ref[(t_ref >= lo) & (t_ref < hi)]
        base = time_base(inside, rate) if inside.size >= 2 else inside
        if base.size < 2:
            if isinstance(split, list):
                raise ValueError(f"split: expected at least 2 samples of the reference {ref_topic!r} in "
                                 f"range {k} ({split[k][0]:g} s to {split[k][1]:g} s), got {base.size}")
            continue
        where = ("" if split is None else f"demonstration {len(demos)}: ") + "topic "
        streams, made, report = align_sources(p, base, sources, max_gap=max_gap, on_gap=on_gap, where=where)
        metadata = {**common, "t0": (origin + round(base[0] * 1e9)) / 1e9, "streams": made, "topics": report}
        if split is not None:
            metadata.update(index=len(demos), split=[round(float(base[0] - t_ref[0]), 9),
                                                     round(float(base[-1] - t_ref[0]), 9)])
        with reading(p, "invalid recording"):
            demos.append(Demonstration(base - base[0], streams, metadata))
    if not demos:
        raise FormatError(p, f"split {split!r} leaves no piece with at least 2 samples of {ref_topic!r}")
    return demos


def _sources(p, mapping, samples, origin, joint_names, repair_time, ref_topic, hold):
    """Each topic as a :class:`Source`, the joint names, and how many stamps the reference dropped."""
    sources, names, dropped = {}, {}, 0
    for topic, s in samples.items():
        name = mapping[topic]
        columns = None
        if s.family == "joint_state":
            names[name] = list(s.names)
        if name == "joints":
            order = joint_names
            if order is None and set(s.names) == set(UR_JOINT_NAMES):
                order = UR_JOINT_NAMES  # a UR driver publishes alphabetically: chain order, as read_robot_h5
            if order is not None:
                missing = [n for n in order if n not in s.names]
                if missing:
                    raise FormatError(p, f"joints {missing} are not on {topic!r}, which has {s.names}")
                columns = [s.names.index(n) for n in order]
                names["joints"] = list(order)
        clock = _clock_kind(s)
        t_k, rows = s.take(origin, columns)
        t_k, rows, n_drop = check_clock(p, t_k, rows, repair_time=repair_time,
                                        where=f"topic {topic!r} ({clock} clock)")
        dropped = n_drop if topic == ref_topic else dropped
        if name == "joints":
            # Angles recorded wrapped to (-pi, pi]: a 2 pi jump is not motion. Column by column, as
            # np.unwrap's temporaries are the size of its input.
            for k in range(rows.shape[1]):
                rows[:, k] = np.unwrap(rows[:, k])
        held = (name in hold) if hold is not None else (s.family == "gripper_command"
                                                        or s.msgtype in DISCRETE_TYPES)
        if name == "pose":
            parts = {"position": (0, 3, "linear"), "orientation": (3, 7, "slerp")}
        elif name == "wrench":
            parts = {"force": (0, 3, "linear"), "torque": (3, 6, "linear")}
        else:
            parts = {name: (0, rows.shape[1], "hold" if held else "linear")}
        info = {"stream": name, "type": s.msgtype, "clock": clock, "held": held}
        sources[topic] = Source(t_k, rows, parts, checked=s.stamped, info=info)
    return sources, names, dropped
