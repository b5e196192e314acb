"""The web view in a real browser: headless Chromium over the written site and over the server.

The session's Chromium (the ``chromium`` fixture) opens each page and waits
until ``assets/view.js`` has drawn every figure; each test then reads what the
page shows, what it asked the network for, and what its console said.
"""

from __future__ import annotations

import re

import pytest

from skillbank.pipeline import Library
from skillbank.plotting._view import write_view
from skillbank.plotting._view_server import ViewServer

from .conftest import HOSTILE

#: A point of a drawn member (trace, sample) in the page's pixels: the scene camera's own projection.
PROJECT = """(([id, trace, k]) => {
  const gd = document.getElementById(id), sc = gd._fullLayout.scene._scene;
  const c = sc.glplot.cameraParams, s = sc.dataScale, d = gd._fullData[trace];
  const mul = (m, v) => [0, 1, 2, 3].map(j => [0, 1, 2, 3].reduce((a, i) => a + m[4 * i + j] * v[i], 0));
  const p = mul(c.projection, mul(c.view, mul(c.model, [d.x[k] * s[0], d.y[k] * s[1], d.z[k] * s[2], 1])));
  const r = sc.container.getBoundingClientRect();
  return [r.left + (0.5 * p[0] / p[3] + 0.5) * r.width, r.top + (0.5 - 0.5 * p[1] / p[3]) * r.height];
})"""


@pytest.fixture(scope="module")
def site(view_library, tmp_path_factory):
    """The library's view written once as files: ``(folder, its file:// URL with a trailing slash)``."""
    out = tmp_path_factory.mktemp("site") / "view"
    with Library(view_library["path"], readonly=True) as lib:
        write_view(lib, out, page_size=4)
    return out, out.as_uri() + "/"


@pytest.fixture(scope="module")
def served(view_library):
    """The same library served by :class:`ViewServer` on a free port of 127.0.0.1; its URL."""
    with ViewServer(lambda: Library(view_library["path"], readonly=True), page_size=4, log=None) as server:
        server.start()
        yield server.url


def _only_the_site(visit, root: str) -> None:
    outside = [u for u in visit.requests if not u.startswith(root)]
    assert outside == [], outside
    assert visit.console_errors() == [] and visit.errors == [] and visit.dialogs == []
    assert visit.ready == "1"


def test_the_index_lists_every_skill_with_its_label_as_text(visit, site, view_library):
    _, root = site
    v = visit(root + "index.html")
    rows = v.page.locator("table.skills tbody tr")
    skills = view_library["summary"]["skills"]
    assert rows.count() == len(skills) >= 3
    for row, skill in zip(rows.all(), skills, strict=True):
        cells = [c.inner_text() for c in row.locator("td").all()]
        assert cells[0] == f"cluster {skill['cluster']}" and cells[2] == str(skill["count"])
        if skill["label"] is not None:
            assert cells[1].startswith(skill["label"])
    # the hostile label is shown, character for character, and no element was made of it
    straight = rows.nth(view_library["straight"]).locator("td").nth(1)
    assert straight.inner_text() == f"{HOSTILE} (given)"
    assert v.page.locator("img").count() == 0
    assert "own-label ×1" in rows.nth(view_library["straight"]).inner_text()
    # the bowed reaches' cluster has no label of its own: the one its labelled member carries is inferred
    arc = rows.nth(view_library["bowed"]).locator("td")
    assert arc.nth(1).inner_text() == "arc (inferred, from its labelled members)"
    assert arc.nth(5).inner_text() == "arc ×1"
    _only_the_site(v, root)


def test_a_skill_page_draws_its_members_and_pointing_at_one_names_it(visit, site, view_library):
    _, root = site
    k = view_library["straight"]
    v = visit(root + f"skill-{k}.html")
    members = [int(c) for c in v.page.locator("table.members tbody tr td:first-child").all_inner_texts()]
    assert len(members) == 4  # the first page of 6, page_size 4
    drawn = v.page.evaluate("document.getElementById('members').data.map(t => t.customdata[0][0])")
    assert drawn == members and v.page.locator("#members canvas").count() >= 1
    assert v.page.locator("h1").inner_text() == f"cluster {k}: {HOSTILE} (given)"
    # a real pointer over a sample of the third member: the page says which primitive, demonstration, range
    x, y = v.page.evaluate(PROJECT, ["members", 2, 30])
    v.page.mouse.move(x - 1, y)
    v.page.mouse.move(x, y)
    v.page.wait_for_function("document.getElementById('hover-info').hasAttribute('data-primitive')",
                             timeout=5000)
    shown = v.page.inner_text("#hover-info")
    assert re.fullmatch(rf"primitive {members[2]} · demonstration \d+ · samples 0:60 · t 0\.000–1\.000 s",
                        shown), shown
    # the next page holds the other two members
    v.page.click("text=next >")
    v.page.wait_for_selector("body[data-ready]")
    assert v.page.url.endswith(f"skill-{k}-2.html")
    assert v.page.locator("table.members tbody tr").count() == 2
    _only_the_site(v, root)


def test_a_demonstration_page_draws_its_streams_and_cuts_with_their_support(visit, site, view_library):
    _, root = site
    v = visit(root + f"demonstration-{view_library['segmented']}.html")
    assert v.page.locator("div.figure").count() == 3  # position, gripper, force
    shapes = v.page.evaluate("document.getElementById('stream-0').layout.shapes.length")
    cuts = v.page.locator("table.cuts tbody tr")
    assert cuts.count() == shapes == 2
    assert "gripper" in cuts.nth(0).locator("td").nth(4).inner_text()
    _only_the_site(v, root)


def test_the_planning_page_shows_hostile_pddl_as_text(visit, site):
    _, root = site
    v = visit(root + "planning.html")
    assert "</pre><script>alert(2)</script>" in v.page.inner_text("pre.action")
    assert "</script><script>alert(3)</script>" in v.page.inner_text("pre.binding")
    assert v.page.locator("main script").count() == 0
    _only_the_site(v, root)


def test_the_served_view_is_the_same_and_loads_only_from_the_server(visit, served, view_library):
    v = visit(served)
    assert v.response.status == 200
    assert v.response.headers["content-security-policy"].endswith("frame-ancestors 'none'")
    assert v.page.locator("table.skills tbody tr").count() == len(view_library["summary"]["skills"])
    _only_the_site(v, served)
    k = view_library["straight"]
    v = visit(served + f"skill-{k}-2.html")
    assert v.page.evaluate("document.getElementById('members').data.length") == 2
    _only_the_site(v, served)
