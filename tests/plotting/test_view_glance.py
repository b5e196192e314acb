"""The web view read at a glance (issue 44, item 6), in headless Chromium.

plotly's toolbar sits in a top margin of its own and covers no legend entry;
the stacked plots of one demonstration share their plot area, so one cut is
at one x in all of them; streams' columns are named (x, y, z) with the unit
on the y axis; the bar above a skill's plot says what it is for before the
pointer is over a path.
"""

from __future__ import annotations

import pytest

from skillbank.pipeline import Library
from skillbank.plotting._view import write_view

#: Every figure of the page: its plot area, its cut lines' x and the boxes of its toolbar and legend entries.
MEASURE = """(() => Array.from(document.querySelectorAll("div.figure[data-figure]")).map(div => {
  const box = e => { const r = e.getBoundingClientRect(); return [r.left, r.top, r.right, r.bottom]; };
  const full = div._fullLayout, left = div.getBoundingClientRect().left;
  const bar = div.querySelector(".modebar");
  return {id: div.id, area: full._size ? [full._size.l, full._size.w] : null,
          cuts: (full.shapes || []).map(s => left + full._size.l + full.xaxis.l2p(s.x0)),
          toolbar: bar ? box(bar) : null,
          entries: Array.from(div.querySelectorAll(".legend .traces")).map(box),
          names: div.data.map(d => d.name), ytitle: full.yaxis ? full.yaxis.title.text : null};
}))"""


def _overlap(a, b):
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


@pytest.fixture(scope="module")
def root(view_library, tmp_path_factory):
    out = tmp_path_factory.mktemp("glance") / "view"
    with Library(view_library["path"], readonly=True) as lib:
        write_view(lib, out, page_size=4)
    return out.as_uri() + "/"


def _figures(v):
    for div in v.page.locator("div.figure[data-figure]").all():
        div.hover()  # plotly shows its toolbar while the pointer is over the figure
    return v.page.evaluate(MEASURE)


def test_stacked_streams_share_one_time_axis_and_name_their_columns(visit, root, view_library):
    v = visit(root + f"demonstration-{view_library['segmented']}.html")
    figures = _figures(v)
    assert [f["id"] for f in figures] == ["stream-0", "stream-1", "stream-2"]  # position, gripper, force
    assert len({tuple(f["area"]) for f in figures}) == 1  # one plot area: left margin and width
    cuts = [f["cuts"] for f in figures]
    assert len(cuts[0]) == 2 and all(c == pytest.approx(cuts[0], abs=0.5) for c in cuts)  # pixels
    assert figures[0]["names"] == ["x", "y", "z"] and figures[2]["ytitle"] == "(N)"
    assert figures[0]["ytitle"] == "(as recorded)"
    assert "column" not in " ".join(v.page.locator("h3").all_inner_texts())
    for f in figures:
        assert f["toolbar"] is not None
        assert not any(_overlap(f["toolbar"], e) for e in f["entries"]), f["id"]


def test_a_skill_page_toolbar_covers_no_legend_entry_and_its_bar_says_what_it_is(visit, root, view_library):
    v = visit(root + f"skill-{view_library['straight']}.html")
    assert v.page.inner_text("#hover-info") == "Point at a path to see which primitive it is."  # before any
    [members] = _figures(v)
    assert members["toolbar"] is not None and len(members["entries"]) == 4
    assert not any(_overlap(members["toolbar"], e) for e in members["entries"])


def test_a_reuse_page_toolbar_covers_no_legend_entry(visit, cli, view_library, tmp_path):
    db = tmp_path / "lib.db"
    db.write_bytes(view_library["path"].read_bytes())
    code, _, err = cli("library", "reuse", db, "--skill", str(view_library["bowed"]), "--goal", "0.5,0.5,0.2",
                       "--view", tmp_path / "view")
    assert code == 0, err
    v = visit((tmp_path / "view" / "reuse.html").as_uri())
    [reuse] = _figures(v)
    assert reuse["toolbar"] is not None and len(reuse["entries"]) >= 3  # reproduction, candidates, stored
    assert not any(_overlap(reuse["toolbar"], e) for e in reuse["entries"])
