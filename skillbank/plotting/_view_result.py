"""The result pages of the web view: a reuse (``library reuse --view``) and a plan (``plan --view``).

Each builder returns ``(title, html, figures)``, the form
:class:`~skillbank.plotting._view.LibraryView` takes as an ``extra`` page:
the adapted path in 3-D over the stored and adapted candidates, the
constraints and the obstacles; the joint curves when the result has joints;
and, when it was simulated, the contacts, the buttons and the force on each
button over time. Every name a scene or a library gave is escaped, in the
HTML and in the figures' text.
"""

from __future__ import annotations

import numpy as np

from ._view import PATH_POINTS, STREAM_POINTS, _num, _thin, _xyz, scene
from ._view_html import TOOLBAR, link, stacked_layout, table, text

__all__ = ["reuse_page", "plan_page"]



def _layout_3d(traces) -> dict:
    drawn = [np.column_stack([t["x"], t["y"], t["z"]]) for t in traces]
    return {"margin": {"l": 0, "r": 0, "t": TOOLBAR, "b": 0}, "hovermode": "closest",
            "scene": scene(drawn, unit="m")}


def _line(Y, name: str, *, colour: str, width: float, dash: str = "solid", group: str | None = None,
          show: bool = True) -> dict:
    """A path as a 3-D line; ``name`` on hover, ``group`` (when given) its legend entry."""
    Y = _xyz(Y)[_thin(len(Y), PATH_POINTS * 5)]
    trace = {"type": "scatter3d", "mode": "lines", "name": text(group or name), "x": Y[:, 0], "y": Y[:, 1],
             "z": Y[:, 2], "line": {"color": colour, "width": width, "dash": dash},
             "hovertemplate": f"{text(name)}<extra></extra>", "showlegend": show}
    if group is not None:
        trace["legendgroup"] = group
    return trace


def _points(P, names, *, colour: str, symbol: str, size: int = 6) -> dict:
    P = _xyz(np.asarray(P, dtype=float).reshape(len(names), -1))
    return {"type": "scatter3d", "mode": "markers", "name": text(", ".join(names)) if len(names) < 4 else
            text(names[0].split(" ")[0]), "x": P[:, 0], "y": P[:, 1], "z": P[:, 2],
            "text": [text(n) for n in names], "hovertemplate": "%{text}<extra></extra>",
            "marker": {"color": colour, "size": size, "symbol": symbol}}


def _obstacles(obstacles, names=None) -> list:
    traces = []
    for k, ob in enumerate(obstacles):
        name = f"obstacle {names[k] if names else k + 1}"
        for j, piece in enumerate(ob.outline(24)):
            traces.append(_line(piece, name, colour="#7f7f7f", width=2, group=name, show=j == 0))
    return traces


def _constraint_traces(constraints) -> list:
    if constraints is None:
        return []
    traces = []
    for name, colour, symbol in (("start", "#2ca02c", "circle"), ("goal", "#d62728", "diamond")):
        value = getattr(constraints, name)
        if value is not None:
            traces.append(_points([value], [name], colour=colour, symbol=symbol, size=7))
    if constraints.via:
        traces.append(_points([v.position for v in constraints.via], [f"via {k + 1}" for k in
                                                                      range(len(constraints.via))],
                              colour="#9467bd", symbol="square"))
    return traces + _obstacles(constraints.obstacles)


def _joints(trajectory) -> tuple[dict, str] | tuple[None, str]:
    if "joints" not in trajectory:
        return None, ""
    q = np.asarray(trajectory["joints"], dtype=float)
    names = list(trajectory.metadata.get("joint_names") or [f"joint {j + 1}" for j in range(q.shape[1])])
    keep = _thin(len(q), STREAM_POINTS)
    data = [{"type": "scatter", "mode": "lines", "x": trajectory.t[keep], "y": q[keep, j],
             "name": text(names[j] if j < len(names) else f"joint {j + 1}")} for j in range(q.shape[1])]
    fig = {"data": data, "layout": stacked_layout(trajectory.t, True, "(rad)")}
    return fig, '<h2>Joints</h2><div class="figure small" id="joints" data-figure="joints"></div>'


def _simulation(sim) -> tuple[dict, str]:
    """The simulated result's contacts, buttons, facts and button forces (``sim``: a SimulationResult)."""
    if sim is None:
        return {}, ""
    doc = sim.to_dict()
    parts = [f"<h2>Simulation</h2><p>Replayed in MuJoCo: {doc['duration']:.3f} s, joints tracked within "
             f"{_num(doc['tracking']['joint_max'])} rad, the tool within "
             f"{_num(1000 * doc['tracking']['tool_max'])} mm; {'ok' if doc['ok'] else 'not ok'}.</p>"]
    contacts = [[text(c.get("robot_body")), text(c.get("other")), _num(c.get("t")), _num(c.get("force"))]
                for c in doc["contacts"]]
    parts.append(table(["robot body", "touched", "t (s)", "force (N)"], contacts, cls="contacts")
                 if contacts else "<p>No unintended contact.</p>")
    if doc["buttons"]:
        parts.append(table(["button", "pressed", "peak force (N)", "t (s)"],
                           [[text(b), "yes" if v.get("pressed") else "no", _num(v.get("peak_force")),
                             _num(v.get("t"))] for b, v in doc["buttons"].items()], cls="buttons"))
    if doc["facts"]:
        parts.append(table(["goal fact", "holds"], [[text(f), text(v)] for f, v in doc["facts"].items()],
                           cls="facts"))
    figures = {}
    forces = getattr(sim, "button_force_", None) or {}
    t = getattr(sim, "t_", None)
    if forces and t is not None:
        keep = _thin(len(t), STREAM_POINTS)
        data = [{"type": "scatter", "mode": "lines", "x": np.asarray(t)[keep], "y": np.asarray(f)[keep],
                 "name": text(b)} for b, f in forces.items()]
        figures["buttons"] = {"data": data, "layout": stacked_layout(t, True, "(N)")}
        parts.append('<h3>Force on each button</h3>'
                     '<div class="figure small" id="buttons" data-figure="buttons"></div>')
    return figures, "".join(parts)


def reuse_page(result, *, skill, method: str, constraints=None, stored=(), simulation=None) -> tuple:
    """The page of a reuse: ``(title, html, figures)`` for :class:`~skillbank.plotting._view.LibraryView`.

    Parameters
    ----------
    result : skillbank.selection.ReuseResult
    skill : str or int
        The skill reused (a label or a cluster id).
    method : str
    constraints : skillbank.Constraints, optional
        What the reuse was asked to meet (start, goal, via points, obstacles).
    stored : sequence of (int, ndarray)
        ``(primitive id, positions)`` of the skill's stored primitives, drawn thin.
    simulation : skillbank.simulation.SimulationResult, optional
    """
    traces = [_line(Y, f"stored primitive {pid}", colour="#aec7e8", width=2, group="stored primitives",
                    show=k == 0)
              for k, (pid, Y) in enumerate(stored)]
    for k, (pid, cand) in enumerate(zip(result.used, result.candidates, strict=False)):
        traces.append(_line(cand["position"], f"adapted candidate {pid}", colour="#1f77b4", width=3,
                            dash="dash", group="adapted candidates", show=k == 0))
    traces.append(_line(result.trajectory["position"], "reproduction", colour="#d62728", width=6))
    traces += _constraint_traces(constraints)
    figures = {"reuse": {"data": traces, "layout": _layout_3d(traces)}}
    d = result.to_dict()
    rows = [["skill", text(skill)], ["method", text(method)],
            ["used", text(", ".join(map(str, result.used)))],
            ["constraint error", f"{_num(d['constraint_error'])} m"],
            ["collision", "yes" if d["collision"] else "no"]]
    if "peak_joint_velocity" in d:
        rows.append(["peak joint velocity", f"{_num(d['peak_joint_velocity'])} rad/s"])
    rejected = [[text(pid), text(why)] for pid, why in result.rejected.items()]
    joints, joints_html = _joints(result.trajectory)
    if joints is not None:
        figures["joints"] = joints
    sim_figures, sim_html = _simulation(simulation)
    figures.update(sim_figures)
    body = [f"<h1>Reuse of skill {text(skill)}</h1>",
            "<p>The reproduction (red) over the skill's stored primitives (light) and the adapted candidates "
            "it learned from (dashed), with the task's start, goal, via points and obstacles.</p>",
            table(None, rows, cls="summary"),
            '<div class="figure" id="reuse" data-figure="reuse"></div>',
            "<h2>Rejected candidates</h2>" + (table(["primitive", "why"], rejected, cls="rejected")
                                              if rejected else "<p>None.</p>"),
            joints_html, sim_html, "".join(f'<p class="note">note: {text(n)}</p>' for n in result.notes)]
    return f"reuse of {skill}", "\n".join(body), figures


_STEP_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
                 "#bcbd22", "#17becf")


def plan_page(result, scene, *, skills=None, simulation=None) -> tuple:
    """The page of a plan: ``(title, html, figures)``; ``skills`` maps a label to its skill page's name."""
    skills = skills or {}
    Y = result.trajectory["position"]
    traces = []
    for k, step in enumerate(result.steps):
        name = f"{k + 1}. ({' '.join([step.action, *step.args])})"
        traces.append(_line(Y[step.start:step.stop], name, colour=_STEP_COLOURS[k % len(_STEP_COLOURS)],
                            width=6))
    placed = [(n, o) for n, o in scene.objects.items() if o.position is not None]
    if placed:
        traces.append(_points([o.position for _, o in placed], [f"{n} ({o.type})" for n, o in placed],
                              colour="#333333", symbol="circle", size=5))
    if result.steps:
        traces.append(_points([s.goal for s in result.steps], [f"goal of step {k + 1}" for k in
                                                              range(len(result.steps))],
                              colour="#000000", symbol="x", size=4))
    names = list(scene.obstacles)
    traces += _obstacles([scene.obstacles[n] for n in names], names)
    figures = {"plan": {"data": traces, "layout": _layout_3d(traces)}}
    rows = []
    for k, s in enumerate(result.steps):
        page = skills.get(s.skill)
        rows.append([str(k + 1), text(f"({' '.join([s.action, *s.args])})"),
                     link(page, s.skill) if page else text(s.skill), text(", ".join(map(str, s.used))),
                     f"{s.start}:{s.stop}", _num(s.constraint_error)])
    joints, joints_html = _joints(result.trajectory)
    if joints is not None:
        figures["joints"] = joints
    sim_figures, sim_html = _simulation(simulation)
    figures.update(sim_figures)
    goal = ", ".join(text(g) for g in getattr(scene, "goal", []))
    body = [f"<h1>Plan of {len(result.steps)} step(s)</h1>", f"<p>Goal: {goal or '-'}; largest gap at a join "
            + ", ".join(f"{text(k)} {_num(v)}" for k, v in result.join_error.items())
            + f"; collision {'yes' if result.collision else 'no'}.</p>",
            table(["step", "action", "skill", "primitives used", "samples", "error (m)"], rows, cls="steps"),
            '<div class="figure" id="plan" data-figure="plan"></div>', joints_html, sim_html,
            "".join(f'<p class="note">note: {text(n)}</p>' for n in result.notes)]
    return f"plan of {len(result.steps)} step(s)", "\n".join(body), figures
