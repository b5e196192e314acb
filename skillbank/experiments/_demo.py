"""The main job run by ``make demo``: segmentation on embedded data."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core import POSE_OF, Demonstration
from ..io import atomic_output, load_lasa, write_json
from ..plotting import plot_keypoint_probability, plot_segmentation_summary, plot_segments
from ..robots import robot_model, tool_point
from ..segmentation import segment

__all__ = ["run_segmentation_demo", "synthetic_multistream", "synthetic_ur5e"]


def fresh_library(db: Path) -> None:
    """Remove a demo's library file and its SQLite side files, so a run starts from nothing."""
    for suffix in ("", "-wal", "-shm", "-journal"):
        p = Path(str(db) + suffix)
        if p.exists():
            p.unlink()


def synthetic_multistream(*, n_steps: int = 1200, random_state=0) -> Demonstration:
    """A pick-and-place-like demonstration with known primitive boundaries.

    Three reaching moves between four 3-D waypoints, with minimum-jerk timing;
    a gripper that closes after the first move and opens after the second;
    a contact force while the gripper is closed; slightly uneven sampling.
    The true boundaries are in ``metadata["true_keypoints"]``.

    Examples
    --------
    >>> demo = synthetic_multistream()
    >>> demo.stream_names
    ['position', 'gripper', 'force']
    """
    rng = np.random.default_rng(random_state)
    bounds = np.array([0, n_steps // 3, 2 * n_steps // 3, n_steps])
    dt = 0.01 * (1.0 + 0.2 * rng.uniform(-1, 1, n_steps))
    t = np.concatenate(([0.0], np.cumsum(dt[1:])))
    waypoints = np.array([[0.0, 0.0, 0.3], [0.4, 0.1, 0.1], [0.2, 0.5, 0.2], [0.0, 0.0, 0.3]])
    position = np.empty((n_steps, 3))
    gripper = np.zeros((n_steps, 1))
    for k in range(3):
        a, b = bounds[k], bounds[k + 1]
        s = (t[a:b] - t[a]) / (t[b - 1] - t[a])
        blend = 10 * s**3 - 15 * s**4 + 6 * s**5  # minimum-jerk profile
        position[a:b] = waypoints[k] + blend[:, None] * (waypoints[k + 1] - waypoints[k])
    gripper[bounds[1]:bounds[2]] = 1.0
    force = np.zeros((n_steps, 3))
    force[bounds[1]:bounds[2], 2] = -5.0
    return Demonstration(t, {"position": position, "gripper": gripper, "force": force},
                         {"source": "synthetic", "true_keypoints": bounds[1:-1].tolist()})


#: Joint waypoints (UR5e, radians, chain order) of :func:`synthetic_ur5e`: from above a table,
#: down to an object, over to a second place and back up; the wrist keeps the tool pointing down.
UR5E_WAYPOINTS = np.array([
    [0.00, -1.75, 1.75, -1.57, -1.57, 0.0],
    [0.35, -1.35, 1.95, -2.17, -1.57, 0.35],
    [-0.45, -1.45, 2.05, -2.17, -1.57, -0.45],
    [0.00, -1.75, 1.75, -1.57, -1.57, 0.0],
])


def synthetic_ur5e(*, n_steps: int = 900, random_state=0) -> Demonstration:
    """A kinesthetic-teaching-like UR5e recording: joints, the 2F-85 TCP's pose and gripper, consistent by FK.

    Three minimum-jerk moves through :data:`UR5E_WAYPOINTS` (slightly
    perturbed with ``random_state``) at about 125 Hz; the flange pose is the
    forward kinematics of the joints, so inverse kinematics of any pose near
    the path is reachable; the gripper closes after the first move and opens
    after the second. Embedded data for ``make demo``'s executable reproduction.

    Examples
    --------
    >>> demo = synthetic_ur5e()
    >>> demo.stream_names, demo.metadata["joint_names"][0]
    (['joints', 'position', 'orientation', 'gripper'], 'shoulder_pan_joint')
    """
    robot = robot_model("ur5e")
    rng = np.random.default_rng(random_state)
    waypoints = UR5E_WAYPOINTS + rng.normal(0.0, 0.03, UR5E_WAYPOINTS.shape) * [1, 1, 1, 0, 0, 1]
    waypoints[-1] = waypoints[0]
    bounds = np.array([0, n_steps // 3, 2 * n_steps // 3, n_steps])
    t = np.arange(n_steps) / 125.0
    joints = np.empty((n_steps, 6))
    for k in range(3):
        a, b = bounds[k], bounds[k + 1]
        s = (t[a:b] - t[a]) / (t[b - 1] - t[a])
        blend = 10 * s**3 - 15 * s**4 + 6 * s**5  # minimum-jerk profile
        joints[a:b] = waypoints[k] + blend[:, None] * (waypoints[k + 1] - waypoints[k])
    position, orientation = robot.fk(joints)
    gripper = np.zeros((n_steps, 1))
    gripper[bounds[1]:bounds[2]] = 1.0
    return Demonstration(t, {"joints": joints, "position": position, "orientation": orientation,
                             "gripper": gripper},
                         {"source": "synthetic-ur5e", "joint_names": list(robot.joint_names),
                          "true_keypoints": bounds[1:-1].tolist(), POSE_OF: tool_point(robot)})


def run_segmentation_demo(out, *, shape: str = "NShape") -> dict:
    """Segment a LASA shape and a synthetic multi-stream demo; write figures and a summary.

    Returns
    -------
    dict
        ``{"out": str, "summary": str, "items": [...]}``.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    items = []
    lasa = load_lasa(shape, index=0)
    cases = [(f"lasa_{shape}", lasa, None, 2, "mm"),  # LASA is in mm, as the library demo says
             ("synthetic_multistream", synthetic_multistream(), None, 3, "m")]
    for name, demo, streams, dims, unit in cases:
        result = segment(demo, streams)
        figures = {
            "summary": plot_segmentation_summary(result, out / f"{name}_profiles.png"),
            "probability": plot_keypoint_probability(result, out / f"{name}_probability.png"),
            # the streams a path cannot show (contact, gripper) under it, against time
            "segments": plot_segments(result, out / f"{name}_segments.png", dims=dims, unit=unit,
                                      below=[k for k, s in result.streams.items() if s.kind != "motion"]),
        }
        items.append({
            "name": name, "n_steps": demo.n_steps, "streams": demo.stream_names,
            "n_segments": result.n_segments, "keypoints": result.keypoints.tolist(),
            "keypoint_times": [round(float(x), 4) for x in result.keypoint_times],
            "figures": {k: str(v) for k, v in figures.items()},
        })
    lines = ["# skillbank demo", ""]
    for item in items:
        lines += [f"## {item['name']}", "",
                  f"{item['n_steps']} samples, streams {', '.join(item['streams'])}: "
                  f"**{item['n_segments']} segments**, keypoints {item['keypoints']} "
                  f"(t = {item['keypoint_times']} s).", ""]
        lines += [f"![{k}]({Path(v).name})" for k, v in item["figures"].items()] + [""]
    summary = out / "summary.md"
    with atomic_output(summary) as tmp:  # whole; a link there is replaced, not written through
        tmp.write_text("\n".join(lines))
    write_json({"items": items}, out / "summary.json")
    return {"out": str(out), "summary": str(summary), "items": items}
