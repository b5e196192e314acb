"""The web view's HTML: escaping, the page frame, the style sheet and the script every page loads.

Everything a page shows that a library, a file or a person wrote (labels,
file names, stream names, metadata, PDDL text) goes through :func:`text`,
which escapes it for HTML; the data a figure is drawn from goes through
:func:`script_json`, a JSON block with ``<``, ``>`` and ``&`` written as
``\\u003c`` ... so no string in it can close the ``<script>`` element. Pages
hold no inline script (the Content-Security-Policy forbids it) and load only
``assets/`` of their own site: the browser fetches nothing else.
"""

from __future__ import annotations

import html
import json
import math

import numpy as np

__all__ = ["text", "script_json", "page", "table", "link", "ASSETS_CSS", "ASSETS_JS", "CSP", "CSP_HEADER"]

#: What a page may load: its own site's scripts, styles and images; no connection, frame or form target.
#: Styles may be inline: plotly.js sets them on the elements it draws.
CSP = ("default-src 'none'; script-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data: blob:; "
       "font-src 'self'; connect-src 'none'; worker-src blob:; base-uri 'none'; form-action 'none'")
#: The policy the server sends as a header: the page's own, and no framing (a ``<meta>`` cannot say that).
CSP_HEADER = CSP + "; frame-ancestors 'none'"

_JSON_ESCAPES = {"<": "\\u003c", ">": "\\u003e", "&": "\\u0026", "\u2028": "\\u2028", "\u2029": "\\u2029"}


def text(value) -> str:
    """``value`` as HTML text: ``&``, ``<``, ``>`` and both quotes escaped (usable inside attributes too).

    Examples
    --------
    >>> text("<img src=x onerror=alert(1)>")
    '&lt;img src=x onerror=alert(1)&gt;'
    >>> text(None)
    '-'
    """
    return "-" if value is None else html.escape(str(value), quote=True)


def _plain(value):
    """``value`` with numpy scalars and arrays as Python ones and non-finite floats as None (JSON null)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, np.generic):
        return _plain(value.item())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def script_json(value) -> str:
    """``value`` as JSON safe inside a ``<script>`` element: no ``<``, ``>`` or ``&`` is left raw.

    Non-finite numbers become ``null`` (JSON has none).

    Examples
    --------
    >>> script_json({"label": "</script><b>&"})
    '{"label": "\\\\u003c/script\\\\u003e\\\\u003cb\\\\u003e\\\\u0026"}'
    >>> script_json([1.5, float("nan")])
    '[1.5, null]'
    """
    out = json.dumps(_plain(value), allow_nan=False, ensure_ascii=False)
    for raw, escaped in _JSON_ESCAPES.items():
        out = out.replace(raw, escaped)
    return out


def link(href: str, label) -> str:
    """An ``<a>`` to one of the site's own pages (``href`` is built by the view, ``label`` escaped).

    Examples
    --------
    >>> link("skill-0.html", "<b>")
    '<a href="skill-0.html">&lt;b&gt;</a>'
    """
    return f'<a href="{text(href)}">{text(label)}</a>'


def table(headers, rows, *, cls: str = "") -> str:
    """An HTML table; ``headers`` (None: no header row) are escaped, each cell of ``rows`` is HTML already
    (escape it first)."""
    head = "" if headers is None else \
        "<thead><tr>" + "".join(f"<th>{text(h)}</th>" for h in headers) + "</tr></thead>"
    body = "".join("<tr>" + "".join(f"<td>{cell}</td>" for cell in row) + "</tr>" for row in rows)
    attr = f' class="{text(cls)}"' if cls else ""
    return f"<table{attr}>{head}<tbody>{body}</tbody></table>"


#: Pixels above a plot for plotly's toolbar (about 25 px high, at the figure's top right corner), so that
#: it covers no legend entry and no data.
TOOLBAR = 34
#: The pixels beside a stacked 2-D plot, the same for every one of a page, so that one time is at one x
#: in all of them (a legend on the right, or tick labels that widen the margin, made them differ).
_STACKED_MARGIN = {"l": 70, "r": 12, "t": TOOLBAR, "b": 38}
#: What the columns of a stream the readers name are: axes, quaternion components (scalar-last), joints.
_COLUMNS = {"position": ("x", "y", "z"), "force": ("x", "y", "z"), "torque": ("x", "y", "z"),
            "orientation": ("qx", "qy", "qz", "qw")}


def stream_columns(name: str, n: int) -> list[str]:
    """Names of the ``n`` columns of stream ``name`` for a legend.

    Examples
    --------
    >>> stream_columns("position", 3), stream_columns("joints", 2), stream_columns("gripper", 1)
    (['x', 'y', 'z'], ['joint 1', 'joint 2'], ['gripper'])
    >>> stream_columns("position", 2), stream_columns("odd", 2)
    (['x', 'y'], ['column 1', 'column 2'])
    """
    known = _COLUMNS.get(name, ())
    if n <= len(known):
        return list(known[:n])
    if name == "joints":
        return [f"joint {j + 1}" for j in range(n)]
    return [name] if n == 1 and name.isidentifier() else [f"column {j + 1}" for j in range(n)]


def stacked_layout(t, legend: bool, unit: str, *, shapes=()) -> dict:
    """A plotly layout for one of several 2-D plots over time stacked on a page: fixed margins, the whole
    time range, the legend in a row above the plot (left, clear of the toolbar at the right) and the
    y axis named by its unit (``"(N)"``, ``"(as recorded)"``)."""
    t = np.asarray(t, dtype=float)
    span = [float(t[0]), float(t[-1])] if t.size else [0.0, 1.0]
    return {"margin": dict(_STACKED_MARGIN), "showlegend": legend, "shapes": list(shapes),
            "legend": {"orientation": "h", "x": 0.0, "xanchor": "left", "y": 1.0, "yanchor": "bottom"},
            "xaxis": {"title": {"text": "t (s)"}, "range": span, "automargin": False},
            "yaxis": {"title": {"text": unit}, "automargin": False}}


def page(title, body: str, *, figures: dict | None = None, plotly: bool = False, root: str = "") -> str:
    """A whole page: ``title`` (escaped), ``body`` (HTML), each figure's data as a JSON block.

    ``figures`` maps an element id to ``{"data": [...], "layout": {...}}`` for
    plotly.js; the page's ``<div class="figure" data-figure="id">`` is drawn
    from it by ``assets/view.js``. ``root`` prefixes the asset paths.
    """
    blocks = "".join(f'<script type="application/json" id="{text(fid)}-data">{script_json(fig)}</script>'
                     for fid, fig in (figures or {}).items())
    scripts = (f'<script src="{root}assets/plotly.min.js"></script>' if plotly else "") + \
        f'<script src="{root}assets/view.js"></script>'
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f'<meta http-equiv="Content-Security-Policy" content="{CSP}">'
            '<meta name="viewport" content="width=device-width, initial-scale=1">'
            '<link rel="icon" href="data:,">'  # no favicon request
            f"<title>{text(title)}</title>"
            f'<link rel="stylesheet" href="{root}assets/view.css">{scripts}</head>'
            f'<body><header><a class="home" href="{root}index.html">skillbank library view</a></header>'
            f"<main>{body}</main>{blocks}</body></html>\n")


ASSETS_CSS = """
body { font: 14px/1.45 system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; margin: 0; color: #222; }
header { background: #23395d; padding: 0.5em 1em; }
header a.home { color: #fff; text-decoration: none; font-weight: 600; }
main { padding: 0.5em 1.5em 2em; max-width: 1200px; }
h1 { font-size: 1.5em; margin: 0.6em 0 0.3em; }
h2 { font-size: 1.2em; margin: 1.2em 0 0.4em; }
h3 { font-size: 1.05em; margin: 0.8em 0 0.2em; }
table { border-collapse: collapse; margin: 0.4em 0; }
th, td { border-bottom: 1px solid #ddd; padding: 0.25em 0.7em; text-align: left; vertical-align: top; }
th { background: #f3f5f8; }
td.num, th.num { text-align: right; }
.given { color: #0a6b2d; font-weight: 600; }
.inferred { color: #8a5a00; font-style: italic; }
.cluster { color: #23395d; }
.none { color: #888; }
.figure { width: 100%; height: 560px; border: 1px solid #e3e3e3; }
.figure.small { height: 220px; }
#hover-info { min-height: 1.5em; padding: 0.3em 0.6em; background: #f3f5f8; border-radius: 4px;
  margin: 0.3em 0; }
pre { background: #f7f7f7; padding: 0.6em; overflow-x: auto; white-space: pre-wrap; }
.pages a, .pages span { margin-right: 0.8em; }
.note { color: #555; }
"""

#: Draws every figure of the page from its JSON block and shows what the pointer is over. No network:
#: plotly.js is the site's own copy; text is set with textContent, never as HTML.
ASSETS_JS = """
(function () {
  "use strict";
  function hoverText(point) {
    var c = point.customdata;
    if (!Array.isArray(c)) { return null; }
    return "primitive " + c[0] + " \\u00b7 demonstration " + c[1] + " \\u00b7 samples " + c[2] + ":" + c[3] +
      " \\u00b7 t " + Number(c[4]).toFixed(3) + "\\u2013" + Number(c[5]).toFixed(3) + " s";
  }
  function draw(div) {
    var block = document.getElementById(div.getAttribute("data-figure") + "-data");
    var fig = JSON.parse(block.textContent);
    var config = {responsive: true, displaylogo: false, showSendToCloud: false, showLink: false};
    return window.Plotly.newPlot(div, fig.data, fig.layout, config).then(function () {
      var info = document.getElementById("hover-info");
      if (info && div.on) {
        div.on("plotly_hover", function (event) {
          var shown = hoverText(event.points[0]);
          if (shown !== null) {
            info.textContent = shown;
            info.setAttribute("data-primitive", event.points[0].customdata[0]);
          }
        });
      }
    });
  }
  function start() {
    var divs = Array.prototype.slice.call(document.querySelectorAll("div.figure[data-figure]"));
    var done = divs.length && window.Plotly ? Promise.all(divs.map(draw)) : Promise.resolve();
    done.then(function () { document.body.setAttribute("data-ready", "1"); },
              function (err) { document.body.setAttribute("data-ready", "error"); throw err; });
  }
  if (document.readyState === "loading") {
    document.addEventListener("DOMContentLoaded", start);
  } else {
    start();
  }
})();
"""
