"""The README's screenshot of the web view: `.venv/bin/python docs/make_view_screenshot.py [DEMO_OUT]`.

Opens the view `make demo` wrote (DEMO_OUT/view, default demo_output/view) in Debian's headless Chromium
through playwright (the test extra; no browser is downloaded), points at a member of the WShape skill so
that the page names it, and saves docs/figures/library_view.png.
"""

import sys
from pathlib import Path

from playwright.sync_api import sync_playwright

here = Path(__file__).resolve().parent / "figures"
view = Path(sys.argv[1] if len(sys.argv) > 1 else "demo_output") / "view"
index = (view / "index.html").read_text()
# the skill page of the label WShape, as the index links it
cluster = next(line.split('href="skill-')[1].split(".html")[0] for line in index.split("<tr>")
               if ">WShape</span>" in line)
args = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync"]
project = """(([id, trace, k]) => {
  const gd = document.getElementById(id), sc = gd._fullLayout.scene._scene;
  const c = sc.glplot.cameraParams, s = sc.dataScale, d = gd._fullData[trace];
  const mul = (m, v) => [0, 1, 2, 3].map(j => [0, 1, 2, 3].reduce((a, i) => a + m[4 * i + j] * v[i], 0));
  const p = mul(c.projection, mul(c.view, mul(c.model, [d.x[k] * s[0], d.y[k] * s[1], d.z[k] * s[2], 1])));
  const r = sc.container.getBoundingClientRect();
  return [r.left + (0.5 * p[0] / p[3] + 0.5) * r.width, r.top + (0.5 - 0.5 * p[1] / p[3]) * r.height];
})"""
with sync_playwright() as p:
    browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=args)
    page = browser.new_page(viewport={"width": 1100, "height": 820}, device_scale_factor=1)
    page.goto((view / f"skill-{cluster}.html").resolve().as_uri())
    page.wait_for_selector("body[data-ready='1']")
    page.evaluate("Plotly.relayout('members', {'scene.camera.eye': {x: 0.35, y: -1.1, z: 1.3}})")
    page.wait_for_timeout(300)
    x, y = page.evaluate(project, ["members", 3, 120])
    page.mouse.move(x - 1, y)
    page.mouse.move(x, y)
    page.wait_for_function("document.getElementById('hover-info').hasAttribute('data-primitive')")
    page.screenshot(path=str(here / "library_view.png"), clip={"x": 0, "y": 0, "width": 1100, "height": 820})
    browser.close()
print(f"skill {cluster} (WShape) -> {here / 'library_view.png'}")
