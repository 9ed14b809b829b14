"""The HTML report opened in a real headless Chromium: what does it render?"""

import json
import re
from html import unescape

import pytest
import report_fixtures as _fx

# pytest fixtures shared by the report tests (see report_fixtures.py)
chromium = _fx.chromium
identified = _fx.identified
small_session = _fx.small_session
written_report = _fx.written_report

pytestmark = pytest.mark.browser

# Injected into a copy of the report (the report itself carries no script): after load,
# record every image's decoded size and the rendered headings in a <pre id="probe">.
PROBE = """<script>
window.addEventListener('load', () => {
  const imgs = Array.from(document.images).map(i => [i.complete, i.naturalWidth,
                                                       i.naturalHeight]);
  const heads = Array.from(document.querySelectorAll('h1, h2')).map(h => h.innerText);
  const tables = Array.from(document.querySelectorAll('table')).map(
      t => [t.rows.length, t.getBoundingClientRect().width]);
  const pre = document.createElement('pre');
  pre.id = 'probe';
  pre.textContent = JSON.stringify({imgs, heads, tables,
                                    height: document.body.scrollHeight});
  document.body.appendChild(pre);
});
</script>"""


def _probe(report_html, tmp_path, chromium):
    html = report_html.read_text(encoding="utf-8").replace("</body>", PROBE + "</body>")
    page = tmp_path / "probe.html"
    page.write_text(html, encoding="utf-8")
    r = chromium(["--virtual-time-budget=10000", "--dump-dom", page.as_uri()])
    assert r.returncode == 0, r.stderr[-2000:]
    m = re.search(r'<pre id="probe">(.*?)</pre>', r.stdout, re.S)
    assert m, r.stdout[-2000:]
    return json.loads(unescape(m.group(1)))


def test_chromium_renders_headings_tables_and_decodes_every_image(written_report, tmp_path,
                                                                  chromium):
    rep, files = written_report
    info = _probe(files.html, tmp_path, chromium)
    heads = info["heads"]
    assert heads[0] == rep.title
    for i, s in enumerate(rep.sections, start=1):
        assert f"{i}. {s.title}" in heads
    assert "Positioning (ISO 230-2)" in " ".join(heads)
    assert "Diagonal displacement (ISO 230-6)" in " ".join(heads)
    n_tables = sum(len(s.tables) for s in rep.sections)
    assert len(info["tables"]) == n_tables
    # the ISO 230-2 table has a header row + 9 linear tests and is laid out (width > 0)
    iso = [t for t in info["tables"] if t[0] == 10]
    assert iso and all(w > 100 for _, w in iso)
    imgs = info["imgs"]
    assert len(imgs) == len(rep.figures) >= 5
    for complete, w, h in imgs:
        assert complete and w > 0 and h > 0
    assert info["height"] > 3000  # a long page, not an error page


def test_screenshot_is_not_blank(written_report, tmp_path, chromium):
    import matplotlib.image as mpimg

    _, files = written_report
    shot = tmp_path / "shot.png"
    r = chromium(["--hide-scrollbars", "--window-size=1200,1600", f"--screenshot={shot}",
                  files.html.as_uri()])
    assert r.returncode == 0 and shot.is_file(), r.stderr[-2000:]
    img = mpimg.imread(shot)
    assert img.shape[:2] == (1600, 1200)
    gray = img[..., :3].mean(axis=2)
    assert gray.std() > 0.05  # text, tables and a figure, not a white page
    assert (gray < 0.3).mean() > 0.005  # dark text present
