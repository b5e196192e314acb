"""The web view of a library: its skills, their members in 3-D, demonstrations and their cuts, planning.

:class:`LibraryView` renders every page from the store when it is asked for
one (:meth:`LibraryView.render`), so the same pages are written as a static
site (:func:`write_view`) or served from the live library
(:mod:`skillbank.plotting._view_server`). A skill's members are shown
``page_size`` at a time: a page reads only its own members' samples, so a
skill of thousands of primitives costs one page's worth per request.

The figures are drawn in the browser by plotly.js (extra ``view``; MIT), whose
own copy is written once into ``assets/``: a page loads nothing from outside
its site.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import tempfile
from pathlib import Path

import numpy as np

from ..core._relation_words import describe_relation
from ..core._validation import check_positive
from ..io._arms import arm_of
from ._segmentation import unit_text
from ._view_html import (
    ASSETS_CSS,
    ASSETS_JS,
    TOOLBAR,
    link,
    page,
    stacked_layout,
    stream_columns,
    table,
    text,
)

__all__ = ["LibraryView", "write_view", "write_site", "check_out", "scene", "plotly_js", "PAGE_SIZE",
           "MARKER"]

#: Members drawn and listed on one page of a skill, demonstrations on one page of the list.
PAGE_SIZE = 100
#: Points a member's path is drawn with (it is resampled evenly by sample index when longer).
PATH_POINTS = 200
#: Points a stream is drawn with on a demonstration's page.
STREAM_POINTS = 2000
#: The file that marks a folder as a view written by skillbank, which a new view may replace.
MARKER = ".skillbank-view"
#: The streams shown per demonstration page, at most (each is one small figure).
MAX_STREAMS = 12

_ROUTES = {
    "skill": re.compile(r"skill-(\d{1,18})(?:-([2-9]|[1-9]\d{1,8}))?\.html"),
    "unassigned": re.compile(r"unassigned(?:-([2-9]|[1-9]\d{1,8}))?\.html"),
    "demonstration": re.compile(r"demonstration-(\d{1,18})\.html"),
    "demonstrations": re.compile(r"demonstrations(?:-([2-9]|[1-9]\d{1,8}))?\.html"),
}


def plotly_js() -> bytes:
    """plotly.js as shipped inside the ``plotly`` Python package (extra ``view``); one line if missing."""
    try:
        # optional dependency (extra "view"): only the JavaScript file it ships is used
        from importlib.resources import files

        return (files("plotly") / "package_data" / "plotly.min.js").read_bytes()
    except (ModuleNotFoundError, FileNotFoundError) as exc:
        raise ImportError("the web view needs plotly.js from the plotly package: "
                          "pip install 'skillbank[view]'") from exc


def _paged(name: str, number: int) -> str:
    return f"{name}.html" if number == 1 else f"{name}-{number}.html"


def _pages_nav(name: str, number: int, total: int) -> str:
    if total <= 1:
        return ""
    parts = [link(_paged(name, number - 1), "< previous") if number > 1 else "<span>&lt; previous</span>",
             f"<span>page {number} of {total}</span>",
             link(_paged(name, number + 1), "next >") if number < total else "<span>next &gt;</span>"]
    return f'<p class="pages">{"".join(parts)}</p>'


def _num(x, digits: int = 3) -> str:
    if x is None or (isinstance(x, float) and not np.isfinite(x)):
        return "inf" if isinstance(x, float) and np.isinf(x) else "-"
    return f"{x:.{digits}g}"


def _thin(n: int, most: int) -> np.ndarray:
    """Indices of at most ``most`` of ``n`` samples, evenly spread, first and last kept."""
    if n <= most:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, n - 1, most)).astype(int))


def _xyz(Y: np.ndarray) -> np.ndarray:
    """A position path as 3 columns: 2-D paths on z = 0, 1-D ones along x, wider ones cut to 3."""
    Y = np.asarray(Y, dtype=float).reshape(len(Y), -1)
    if Y.shape[1] >= 3:
        return Y[:, :3]
    return np.column_stack([Y, np.zeros((len(Y), 3 - Y.shape[1]))])


def scene(paths, *, unit: str = "") -> dict:
    """A plotly 3-D scene for ``paths`` (arrays of 3 columns) at one scale on every axis, a flat axis
    (a letter drawn on a table) given a tenth of the largest extent so that it is not stretched.

    Examples
    --------
    >>> s = scene([np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 0.0]])])
    >>> s["aspectratio"], s["zaxis"]["range"]
    ({'x': 0.5, 'y': 1.0, 'z': 0.1}, [-0.1, 0.1])
    """
    suffix = f" ({unit})" if unit else ""
    out = {"aspectmode": "manual", **{f"{a}axis": {"title": {"text": a + suffix}} for a in "xyz"}}
    pts = [np.asarray(P, dtype=float).reshape(-1, 3) for P in paths if len(P)]
    pts = np.concatenate(pts) if pts else np.zeros((0, 3))
    pts = pts[np.isfinite(pts).all(axis=1)]
    if not len(pts):
        return {**out, "aspectmode": "cube"}
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    extent = hi - lo
    span = max(float(extent.max()), 1e-9)
    sides = np.maximum(extent, 0.1 * span)
    centre = 0.5 * (lo + hi)
    for k, a in enumerate("xyz"):
        out[f"{a}axis"]["range"] = [float(centre[k] - 0.5 * sides[k]), float(centre[k] + 0.5 * sides[k])]
    out["aspectratio"] = {a: round(float(sides[k] / sides.max()), 6) for k, a in enumerate("xyz")}
    return out


class LibraryView:
    """The pages of a library's web view, rendered from its store on demand.

    Parameters
    ----------
    library : skillbank.pipeline.Library or skillbank.store.Store
        An open library (read-only is enough). The view reads it on every
        :meth:`render`, so a served view shows what the library holds now.
    page_size : int, default=PAGE_SIZE
        Members per page of a skill (and demonstrations per page of their list).
    extra : dict, optional
        ``{page name: (title, html, figures)}`` of further pages (a reuse's or a plan's
        result), linked from the index.
    snapshot : bool, default=False
        Read the library's clustering and primitives once, at the first page,
        and render every page from that picture (a static site); by default each
        page reads the library as it is then (a served view).

    Examples
    --------
    >>> import os, tempfile
    >>> from skillbank import Demonstration
    >>> from skillbank.store import open_store
    >>> t = np.linspace(0.0, 1.0, 40)
    >>> with open_store(os.path.join(tempfile.mkdtemp(), "lib.db")) as store:
    ...     demo = Demonstration.from_array(np.column_stack([t, t, t]), t)
    ...     _ = store.add_demonstration(demo, [(0, 20), (20, 40)])
    ...     view = LibraryView(store)
    ...     "demonstration-1.html" in view.pages(), view.render("skill-7.html") is None
    (True, True)
    """

    def __init__(self, library, *, page_size: int = PAGE_SIZE, extra: dict | None = None,
                 snapshot: bool = False):
        self.store = getattr(library, "store", library)
        self.page_size = check_positive(page_size, name="page_size", integer=True)
        self.extra = dict(extra or {})
        self._snapshot = bool(snapshot)
        self._memo = None

    # -- routes ----------------------------------------------------------------------------------
    def pages(self) -> list[str]:
        """Every page of the site, by name (what :func:`write_view` writes)."""
        out = ["index.html", "planning.html", *self.extra]
        state = self._state()
        for k in range(state["n_clusters"]):
            n = sum(1 for c in state["clusters"].values() if c == k)
            out += [_paged(f"skill-{k}", p) for p in range(1, self._n_pages(n) + 1)]
        out += [_paged("unassigned", p) for p in range(1, self._n_pages(len(state["unassigned"])) + 1)]
        ids = state["demonstrations"]
        out += [_paged("demonstrations", p) for p in range(1, self._n_pages(len(ids)) + 1)]
        out += [f"demonstration-{d}.html" for d in ids]
        return out

    def render(self, name: str) -> str | None:
        """The HTML of page ``name`` (``"index.html"``, ``"skill-3-2.html"``, ...); None: no such page."""
        if name == "index.html":
            return self._index()
        if name == "planning.html":
            return self._planning()
        if name in self.extra:
            title, body, figures = self.extra[name]
            return page(title, body, figures=figures, plotly=bool(figures))
        for kind, pattern in _ROUTES.items():
            m = pattern.fullmatch(name)
            if m is None:
                continue
            if kind == "skill":
                return self._skill(int(m.group(1)), int(m.group(2) or 1))
            if kind == "unassigned":
                return self._skill(None, int(m.group(1) or 1))
            if kind == "demonstration":
                return self._demonstration(int(m.group(1)))
            return self._demonstration_list(int(m.group(1) or 1))
        return None

    def _n_pages(self, n: int) -> int:
        return max(1, -(-n // self.page_size))

    # -- what the library holds ------------------------------------------------------------------
    def _state(self) -> dict:
        """The current version, its clusters and labels, every primitive without samples (with features)

        Read at each call, unless the view is a ``snapshot`` (one picture for a whole static site).
        """
        if self._memo is not None:
            return self._memo
        store = self.store
        version = store.current_version()
        prims = store.primitives(load=False)
        info = store.version(version) if version is not None else None
        n = 0 if info is None else int(info["n_clusters"])
        clusters = {p.id: p.cluster for p in prims if p.cluster is not None}
        out = {"version": version, "info": info, "n_clusters": n, "prims": prims, "clusters": clusters,
               "unassigned": [p.id for p in prims if p.cluster is None],
               "labels": {} if version is None else store.cluster_labels(version),
               "inferred": {} if version is None else store.inferred_labels(version),
               "demonstrations": store.demonstration_ids()}
        out["features"] = {p.id: p.features for p in prims
                           if p.cluster is not None and p.features is not None}
        if self._snapshot:
            self._memo = out
        return out

    def _skill_label(self, state, cluster) -> tuple:
        """``(label, source, note)`` of a cluster as ``library list`` tells it: ``"given"`` (the cluster's
        own label), ``"inferred"`` (the one label its labelled primitives agree on), or no label; the note
        says when a given label was carried over from the previous version by the reclustering
        (:func:`~skillbank.pipeline.carry_labels`: more than half of the new cluster's members had it)."""
        if cluster in state["labels"]:
            label, note = state["labels"][cluster], ""
            carried = self._carried(state)
            if carried.get(cluster) == label:
                note = f"carried from version {carried['from']}"
            return label, "given", note
        if cluster in state["inferred"]:
            return state["inferred"][cluster], "inferred", "from its labelled members"
        return None, None, ""

    def _carried(self, state) -> dict:
        """``{cluster: label}`` the reclustering carried from the previous version (and ``"from"``)."""
        if "carried" not in state:
            state["carried"] = {}
            earlier = [v["version"] for v in self.store.versions() if v["version"] < state["version"]]
            if earlier and state["labels"]:
                # the pipeline's own rule, to tell a carried label from one given since (it imports sklearn)
                from ..pipeline import carry_labels

                old = earlier[-1]
                state["carried"] = {**carry_labels(self.store.members(old), self.store.cluster_labels(old),
                                                   dict(state["clusters"])), "from": old}
        return state["carried"]

    @staticmethod
    def _separation(state) -> dict:
        """``{cluster: (separation from its nearest other cluster, that cluster)}`` of the current version."""
        from ..clustering._em import pairwise_separation  # the clustering's own measure of a gap

        feats, n = state["features"], state["n_clusters"]
        ids = sorted(feats)
        if n < 2 or not ids:
            return {}
        X = np.array([np.asarray(feats[i], dtype=float) for i in ids])
        labels = np.array([state["clusters"][i] for i in ids])
        delta = pairwise_separation(X, labels, n)
        np.fill_diagonal(delta, np.inf)
        return {k: (float(delta[k].min()), int(np.argmin(delta[k]))) for k in range(n)}

    # -- pages -------------------------------------------------------------------------------------
    @staticmethod
    def _label_cell(label, source, note: str = "") -> str:
        """A label with where it comes from (given, cluster, inferred), escaped."""
        if label is None:
            return '<span class="none">-</span>'
        kind = source or "given"
        said = f"{kind}, {note}" if note else kind
        return f'<span class="label {kind}">{text(label)}</span> <span class="note">({text(said)})</span>'

    def _index(self) -> str:
        state = self._state()
        store, version, info = self.store, state["version"], state["info"]
        prims = state["prims"]
        body = [f"<h1>Library {text(store.location)}</h1>",
                f"<p>{len(state['demonstrations'])} demonstration(s), {len(prims)} primitive(s); "
                + ("no clustering yet (run <code>skillbank library cluster</code>)" if version is None else
                   f"clustering version {version} of {text(info['created'])}, {state['n_clusters']} skill(s)")
                + f". {link(_paged('demonstrations', 1), 'Demonstrations')} · "
                f"{link('planning.html', 'Planning')}</p>"]
        if version is not None:
            params = info["params"] or {}
            threshold = params.get("min_separation")
            body.append(f"<p class=\"note\">{text(params.get('method', 'clustering'))} on "
                        f"{text(params.get('features'))} features, stretch {text(params.get('stretch'))}, "
                        f"criterion {text(params.get('criterion'))}; a cluster is kept when it is at least "
                        f"{text(threshold)} apart from every other (separation along the line joining their "
                        "means, in pooled standard deviations).</p>")
            separation = self._separation(state)
            counts = np.bincount(list(state["clusters"].values()), minlength=state["n_clusters"])
            own = {}
            for p in prims:
                if p.cluster is not None and p.label is not None and p.label_source == "given":
                    own.setdefault(p.cluster, {}).setdefault(p.label, 0)
                    own[p.cluster][p.label] += 1
            rows = []
            for k in range(state["n_clusters"]):
                gap = separation.get(k)
                sep = "-" if gap is None else f"{_num(gap[0])} from cluster {gap[1]}"
                mine = ", ".join(f"{text(lab)} ×{c}" for lab, c in sorted(own.get(k, {}).items()))
                rows.append([link(f"skill-{k}.html", f"cluster {k}"),
                             self._label_cell(*self._skill_label(state, k)),
                             f'<span class="num">{int(counts[k])}</span>', str(version), sep,
                             mine or '<span class="none">-</span>'])
            body += ["<h2>Skills</h2>", table(["skill", "label", "members", "version",
                                               "separation (nearest cluster)", "members' own labels (given)"],
                                              rows, cls="skills")]
        if state["unassigned"]:
            body.append(f"<p>{len(state['unassigned'])} primitive(s) in no cluster: "
                        f"{link('unassigned.html', 'unassigned')}.</p>")
        if self.extra:
            items = "".join(f"<li>{link(name, title)}</li>" for name, (title, *_) in self.extra.items())
            body.append(f"<h2>Results</h2><ul>{items}</ul>")
        versions = store.versions()
        if len(versions) > 1:
            body += ["<h2>Clustering versions</h2>", table(
                ["version", "created", "skills", "primitives", "features"],
                [[str(v["version"]), text(v["created"]), str(v["n_clusters"]),
                  text((v["params"] or {}).get("n_primitives")), text((v["params"] or {}).get("features"))]
                 for v in versions])]
        return page(f"library {store.location}", "\n".join(body))

    def _skill(self, cluster, number: int) -> str | None:
        state = self._state()
        if cluster is None:
            ids = state["unassigned"]
            name, title = "unassigned", "primitives in no cluster"
        else:
            if not 0 <= cluster < state["n_clusters"]:
                return None
            ids = sorted(i for i, c in state["clusters"].items() if c == cluster)
            name, title = f"skill-{cluster}", f"cluster {cluster}"
        total = self._n_pages(len(ids))
        if number > total:
            return None
        shown = set(ids[(number - 1) * self.page_size: number * self.page_size])
        members = [p for p in state["prims"] if p.id in shown]
        demos = self.store.demonstrations(sorted({p.demonstration_id for p in members})) if members else {}
        label, source, note = self._skill_label(state, cluster) if cluster is not None else (None, None, "")
        # what each member acts on, recorded when it was added (the primitive's place in its demonstration)
        place, count = {}, {}
        for q in sorted(state["prims"], key=lambda q: (q.demonstration_id, q.start)):
            place[q.id] = count[q.demonstration_id] = count.get(q.demonstration_id, -1) + 1
        relations = {d: (self.store.provenance(d) or {}).get("relations") for d in demos}
        traces, rows = [], []
        for p in members:
            demo = demos[p.demonstration_id]
            t = demo.t
            t0, t1 = float(t[p.start]), float(t[p.stop - 1])
            if "position" in demo.streams:
                Y = _xyz(demo["position"][p.start:p.stop])[_thin(p.n_steps, PATH_POINTS)]
                cd = [[p.id, p.demonstration_id, p.start, p.stop, t0, t1]] * len(Y)
                traces.append({"type": "scatter3d", "mode": "lines+markers", "name": f"primitive {p.id}",
                               "x": Y[:, 0], "y": Y[:, 1], "z": Y[:, 2], "customdata": cd,
                               "marker": {"size": 2}, "line": {"width": 4},
                               "hovertemplate": f"primitive {p.id}<extra></extra>"})
            lab = self._label_cell(p.label, p.label_source)
            known = relations.get(p.demonstration_id)
            acts = known[place[p.id]] if isinstance(known, list) and place[p.id] < len(known) else None
            arm = arm_of(demo.metadata)
            rows.append([str(p.id), link(f"demonstration-{p.demonstration_id}.html",
                                         f"demonstration {p.demonstration_id}"),
                         "-" if arm is None else str(arm),
                         f"{p.start}:{p.stop}", f"{t0:.3f} – {t1:.3f}",
                         text(describe_relation(acts) if isinstance(acts, dict) else "") or "-", lab])
        drawn = [np.column_stack([tr["x"], tr["y"], tr["z"]]) for tr in traces]
        # the top margin holds plotly's toolbar; the legend starts under it (it covered the first entry)
        layout = {"margin": {"l": 0, "r": 0, "t": TOOLBAR, "b": 0}, "showlegend": len(traces) <= 30,
                  "legend": {"x": 1.0, "xanchor": "right", "y": 1.0, "yanchor": "top"}, "scene": scene(drawn),
                  "hovermode": "closest", "uirevision": "keep"}
        heading = self._label_cell(label, source, note) if cluster is not None else ""
        body = [f"<h1>{text(title)}: {heading}</h1>",
                f"<p>{len(ids)} member(s)" + (f" in clustering version {state['version']}"
                                              if cluster is not None else "")
                + f"; showing {len(members)} (page {number} of {total}). Drag to rotate, scroll to zoom."
                "</p>", _pages_nav(name, number, total),
                # what the pointer is over; until then, how to use it (an empty bar read as a broken one)
                '<div id="hover-info" class="note">Point at a path to see which primitive it is.</div>']
        figures = {}
        if traces:
            body.append('<div class="figure" id="members" data-figure="members"></div>')
            figures["members"] = {"data": traces, "layout": layout}
        else:
            body.append('<p class="note">No member has a position stream to draw.</p>')
        headers = ["primitive", "demonstration", "arm", "samples", "time (s)", "acts on", "label"]
        body += ["<h2>Members</h2>", table(headers, rows, cls="members"), _pages_nav(name, number, total)]
        return page(f"{title} ({label or 'no label'})", "\n".join(body), figures=figures, plotly=bool(traces))

    def _demonstration_list(self, number: int) -> str | None:
        state = self._state()
        ids = state["demonstrations"]
        total = self._n_pages(len(ids))
        if number > total:
            return None
        shown = ids[(number - 1) * self.page_size: number * self.page_size]
        count = {}
        for p in state["prims"]:
            count[p.demonstration_id] = count.get(p.demonstration_id, 0) + 1
        rows = [[link(f"demonstration-{d}.html", f"demonstration {d}"), str(count.get(d, 0))] for d in shown]
        body = [f"<h1>Demonstrations</h1><p>{len(ids)} demonstration(s).</p>",
                _pages_nav("demonstrations", number, total),
                table(["demonstration", "primitives"], rows, cls="demonstrations"),
                _pages_nav("demonstrations", number, total)]
        return page("demonstrations", "\n".join(body))

    def _demonstration(self, did: int) -> str | None:
        if did not in set(self.store.demonstration_ids()):
            return None
        demo = self.store.demonstrations([did])[did]
        prov = self.store.provenance(did) or {}
        prims = sorted(self.store.primitives(demonstration=did, load=False), key=lambda p: p.start)
        cuts = [p.start for p in prims[1:]]
        t = demo.t
        keep = _thin(demo.n_steps, STREAM_POINTS)
        figures, plots = {}, []
        for k, (sname, Y) in enumerate(list(demo.streams.items())[:MAX_STREAMS]):
            Y = np.asarray(Y, dtype=float).reshape(demo.n_steps, -1)
            lo = float(np.nanmin(Y)) if np.isfinite(Y).any() else 0.0
            hi = float(np.nanmax(Y)) if np.isfinite(Y).any() else 1.0
            names, unit = stream_columns(sname, Y.shape[1]), unit_text(sname)
            data = [{"type": "scatter", "mode": "lines", "x": t[keep], "y": Y[keep, j], "name": names[j],
                     "hovertemplate": f"{names[j]}: %{{y:.4g}} {unit} at %{{x:.3f}} s<extra></extra>"}
                    for j in range(min(Y.shape[1], 16))]
            shapes = [{"type": "line", "x0": float(t[c]), "x1": float(t[c]), "y0": lo, "y1": hi,
                       "line": {"color": "#c0392b", "width": 1.5, "dash": "dot"}} for c in cuts]
            fid = f"stream-{k}"
            figures[fid] = {"data": data, "layout": stacked_layout(t, Y.shape[1] > 1, unit, shapes=shapes)}
            said = f"{', '.join(names[:16])} {unit}" if Y.shape[1] > 1 else unit  # one column: its unit
            plots.append(f"<h3>{text(sname)} <span class=\"note\">{text(said)}</span></h3>"
                         f'<div class="figure small" id="{fid}" data-figure="{fid}"></div>')
        support = prov.get("cut_support")
        rows = []
        for k, c in enumerate(cuts):
            found = None
            if isinstance(support, list):
                found = next((s for s in support if isinstance(s, dict) and s.get("at") == c), None)
            if found is None:
                why = "not recorded" if not isinstance(support, list) else "-"
            else:
                streams = found.get("streams") or {}
                why = ", ".join(f"{text(s)} ({_num(e, 2)})" for s, e in streams.items()) or "-"
            rows.append([str(k + 1), str(c), f"{float(t[c]):.3f}", f"{prims[k].id} | {prims[k + 1].id}", why])
        prim_rows = [[str(p.id), f"{p.start}:{p.stop}",
                      f"{float(t[p.start]):.3f} – {float(t[p.stop - 1]):.3f}",
                      "-" if p.cluster is None else link(f"skill-{p.cluster}.html", f"cluster {p.cluster}"),
                      text(p.label)] for p in prims]
        meta = {k: v for k, v in demo.metadata.items()}
        seg = ("cut by " + text(prov.get("method", "the segmenter")) + (f", mode {text(prov['mode'])}"
                                                                         if "mode" in prov else "")
               if prov.get("segment") else "stored whole (not segmented)")
        aside = prov.get("set_aside") or {}
        body = [f"<h1>Demonstration {did}</h1>",
                f"<p>{demo.n_steps} samples over {demo.duration:.3f} s; streams "
                f"{', '.join(text(s) for s in demo.stream_names)}; {seg}; {len(prims)} primitive(s).</p>"]
        if aside:
            body.append("<p class=\"note\">Set aside: " + "; ".join(f"{text(s)} ({text(w)})"
                                                                    for s, w in aside.items()) + "</p>")
        if len(demo.streams) > MAX_STREAMS:
            body.append(f"<p class=\"note\">The first {MAX_STREAMS} of {len(demo.streams)} streams are "
                        "drawn.</p>")
        headers = ["cut", "sample", "t (s)", "between primitives", "supported by (evidence)"]
        body += ["<h2>Cuts</h2>", table(headers, rows, cls="cuts") if rows else "<p>No cut.</p>",
                 "<h2>Streams</h2>", *plots, "<h2>Primitives</h2>",
                 table(["primitive", "samples", "time (s)", "skill", "label"], prim_rows, cls="primitives"),
                 "<h2>Metadata</h2>", f"<pre>{text(json.dumps(meta, indent=1, default=str)[:20000])}</pre>"]
        return page(f"demonstration {did}", "\n".join(body), figures=figures, plotly=bool(figures))

    def _planning(self) -> str:
        found = self.store.descriptions()
        labels = {}
        version = self.store.current_version()
        if version is not None:
            labels = {lab: k for k, lab in self.store.cluster_labels(version).items()}
        body = ["<h1>Planning descriptions</h1>"]
        if not found:
            body.append("<p>No skill has a description (see <code>skillbank library describe</code>).</p>")
        for d in found:
            known = d["label"] in labels
            skill = link(f"skill-{labels[d['label']]}.html", d["label"]) if known else text(d["label"])
            body += [f"<h2>{skill}</h2>",
                     f"<p class=\"note\">revision {text(d['revision'])} of {text(d['created'])}</p>",
                     f"<pre class=\"action\">{text(d['action'])}</pre>",
                     f"<pre class=\"binding\">{text(json.dumps(d['binding'], indent=1))}</pre>"]
        return page("planning descriptions", "\n".join(body))


def _assets() -> dict:
    return {"assets/view.css": ASSETS_CSS.encode(), "assets/view.js": ASSETS_JS.encode(),
            "assets/plotly.min.js": plotly_js()}


def check_out(out, *, name: str = "out") -> Path:
    """``out`` as a Path if a view can be written there (new, empty, or a view written before), else a
    one-line ValueError naming ``name``.

    Examples
    --------
    >>> check_out(__file__)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: out: ... exists and is not a folder
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"{name}: {str(out)!r} exists and is not a folder")
    if out.is_dir() and any(out.iterdir()) and not (out / MARKER).is_file():
        raise ValueError(f"{name}: folder {str(out)!r} is not empty and holds no skillbank view; "
                         "give a new or empty folder")
    if not out.resolve().parent.is_dir():
        raise ValueError(f"{name}: folder {str(out.resolve().parent)!r} does not exist")
    return out


def write_site(files: dict, out) -> Path:
    """Write ``{relative path: bytes}`` as folder ``out`` whole: built beside it, then renamed into place.

    ``out`` must be new, empty, or a view written before (it holds :data:`MARKER`), which is replaced;
    any other folder is refused before anything is written.
    """
    out = check_out(out)
    parent = out.resolve().parent
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=parent))
    try:
        for rel, data in {**files, MARKER: b"written by skillbank library view\n"}.items():
            path = tmp / rel
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)
        os.chmod(tmp, 0o755)
        old = None
        if out.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old.", dir=parent))
            os.replace(out, old / "view")
        os.replace(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
    return out


def write_view(library, out, *, page_size: int = PAGE_SIZE, extra: dict | None = None) -> dict:
    """Write the web view of ``library`` to folder ``out``: every page, then the assets they load.

    Every page is rendered before anything is written; the folder then
    appears whole (:func:`write_site`), so a failure leaves ``out`` as it was.

    Parameters
    ----------
    library : skillbank.pipeline.Library or skillbank.store.Store
    out : str or path-like
        A new or empty folder, or one a previous view was written to (replaced).
    page_size : int, default=PAGE_SIZE
        Members per page of a skill.
    extra : dict, optional
        Further pages, ``{name: (title, html, figures)}`` (see :class:`LibraryView`).

    Returns
    -------
    dict
        ``{"out": folder, "index": index.html, "pages": number of pages}``.

    Examples
    --------
    >>> import os, tempfile
    >>> from skillbank import Demonstration
    >>> from skillbank.store import open_store
    >>> t = np.linspace(0.0, 1.0, 40)
    >>> folder = tempfile.mkdtemp()
    >>> with open_store(os.path.join(folder, "lib.db")) as store:
    ...     _ = store.add_demonstration(Demonstration.from_array(np.column_stack([t, t, t]), t), [(0, 40)])
    ...     write_view(store, os.path.join(folder, "view"))["pages"]
    5
    """
    check_out(out)  # before the work
    view = LibraryView(library, page_size=page_size, extra=extra, snapshot=True)
    files = {name: view.render(name).encode() for name in view.pages()}
    files.update(_assets())
    site = write_site(files, out)
    return {"out": str(site), "index": str(site / "index.html"), "pages": len(files) - 3}
