"""The PDF a customer gets, read back with poppler: nothing cut, sharp figures, readable
labels, one unit spelling, full citations (issue 20, "Deliver 8").

One rendering of a simulated session (the shared ``written_report`` fixture) is read once
per tool (pdftotext, pdfimages) by module-scoped fixtures.
"""

import re
import shutil
import subprocess
import zlib
from html import unescape

import numpy as np
import pytest
import report_fixtures as _fx

from timing import scaled_timeout
from volcal.report.document import Report, Section, Table
from volcal.report.wording import REFERENCES, customer_report, customer_text

# pytest fixtures shared by the report tests (see report_fixtures.py)
identified = _fx.identified
small_session = _fx.small_session
written_report = _fx.written_report

PDFTOTEXT = shutil.which("pdftotext")
PDFIMAGES = shutil.which("pdfimages")
A4_PORTRAIT_PT = (595.44, 841.68)

ELLIPSES = ("…", "...")
# "um" / "urad" standing as a unit (not inside an identifier such as deviation_um)
ASCII_UNIT = re.compile(r"(?<![A-Za-z_µ])u(m|rad)(?![A-Za-z_0-9])")


def _tool(path):
    if path is None:
        pytest.skip("poppler-utils is not installed (make browser-deps installs it)")
    return path


def _pdftotext(pdf, *args):
    r = subprocess.run([_tool(PDFTOTEXT), *args, str(pdf), "-"], capture_output=True,
                       text=True, timeout=scaled_timeout(60))
    assert r.returncode == 0, r.stderr
    return r.stdout


def _squeeze(s: str) -> str:
    """Text without white space: a cell wrapped over lines reads as the same string."""
    return re.sub(r"\s+", "", s)


@pytest.fixture(scope="module")
def customer(written_report):
    """The report as the customer reads it (units and citations as printed)."""
    rep, files = written_report
    return customer_report(rep), files


@pytest.fixture(scope="module")
def raw_text(written_report):
    """The PDF's text in drawing order (a table cell's lines one after the other)."""
    return _pdftotext(written_report[1].pdf, "-raw")


@pytest.fixture(scope="module")
def images(written_report):
    """Rows of ``pdfimages -list``: (page, width, height, x-ppi, y-ppi)."""
    r = subprocess.run([_tool(PDFIMAGES), "-list", str(written_report[1].pdf)],
                       capture_output=True, text=True, timeout=scaled_timeout(60))
    assert r.returncode == 0, r.stderr
    rows = [ln.split() for ln in r.stdout.splitlines()[2:] if ln.strip()]
    return [(int(c[0]), int(c[3]), int(c[4]), float(c[12]), float(c[13])) for c in rows]


def _cells(rep: Report):
    for s in rep.sections:
        for t in s.tables:
            yield from ((t.title, c) for c in t.columns)
            yield from ((t.title, c) for r in t.rows for c in r)


def test_no_ellipsis_and_every_table_cell_whole(customer, raw_text):
    rep, files = customer
    for e in ELLIPSES:
        assert e not in raw_text
    text = _squeeze(raw_text)
    missing = [(title, c) for title, c in _cells(rep) if _squeeze(c) not in text]
    assert missing == []
    # the two tables the issue names, by their full strings (not shortened to 48 characters)
    ident = next(s for s in rep.sections if s.id == "identifiability")
    sugg = next(t for t in ident.tables if t.title == "Suggested extra measurements")
    assert len(sugg.rows) >= 1 and max(len(r[1]) for r in sugg.rows) > 48
    for _, t in sugg.rows:
        assert _squeeze(t) in text
    vol = next(s for s in rep.sections if s.id == "volumetric").tables[0]
    long = [r[2] for r in vol.rows if len(r[2]) > 48]
    assert long and all(_squeeze(t) in text for t in long)
    assert any(t.startswith("largest length of the volumetric error vector, at (") for t in long)
    # paragraphs and warnings whole as well
    for s in rep.sections:
        for p in s.paragraphs + s.warnings:
            assert _squeeze(p) in text, p[:60]


def test_html_cells_whole_and_wrapped(customer):
    rep, files = customer
    html = files.html.read_text(encoding="utf-8")
    body = unescape(html)
    for e in ELLIPSES:
        assert e not in body.split("<body>", 1)[1]
    for title, c in _cells(rep):
        assert c in body, (title, c)
    assert "overflow-wrap: break-word" in html and "text-overflow: ellipsis" not in html


def test_long_cells_wrap_inside_their_column_and_the_page(tmp_path):
    from volcal.report.pdf import write_pdf

    sentence = " ".join(f"word{i:03d}" for i in range(90))  # 720 characters
    token = "x" * 60 + "Y" * 60 + "z" * 60  # no space: broken between characters
    t = Table(["rank", "extra measurement that would help most", "value [µm]"],
              [["1", sentence, "12.34"], ["2", token, "-0.01"], ["3", "short", "(1, 0, 0)"]],
              "Suggested extra measurements")
    pdf = tmp_path / "t.pdf"
    pages = write_pdf(Report("wrap test", [Section("s", "S", tables=[t])]), pdf)
    assert pages == 1
    text = _pdftotext(pdf, "-raw")
    for e in ELLIPSES:
        assert e not in text
    for cell in (sentence, token, "12.34", "-0.01", "(1, 0, 0)"):
        assert _squeeze(cell) in _squeeze(text)
    lines = [ln for ln in text.splitlines() if "word" in ln]
    assert len(lines) >= 5  # wrapped over several lines, not one cut line
    bbox = _pdftotext(pdf, "-bbox")
    xmax = [float(x) for x in re.findall(r'xMax="([\d.]+)"', bbox)]
    # every word inside the text column (7 % margins of the 595 pt wide A4 page)
    assert max(xmax) <= 0.93 * A4_PORTRAIT_PT[0] + 1.0


def test_figures_are_vectors_or_at_least_200_ppi(written_report, images):
    rep, files = written_report
    # rasters: only the parts matplotlib rasterizes (colour bars), each >= 200 ppi
    assert len(images) <= len(rep.figures)
    for page, w, h, xppi, yppi in images:
        assert xppi >= 200 and yppi >= 200, (page, w, h, xppi, yppi)
    # the figure pages carry their labels as text (vector), not as pixels
    text = _pdftotext(files.pdf, "-layout")
    for label in ("positional deviation [µm]", "prior uncertainty removed [%]",
                  "squareness [µrad]", "Z [mm]", "|e| [µm]"):
        assert label in text


def _printed_font_sizes(pdf_bytes: bytes) -> tuple[list[float], int]:
    """Printed size of every font selection (``Tf``) in the page streams [pt].

    matplotlib writes each text as ``a b c d e f cm BT ... /F size Tf ... ET``: the printed
    size is ``size * sqrt(|ad - bc|)``. Also returns the number of ``Tf`` in the streams,
    so that a text written another way cannot escape the check.
    """
    sizes, total = [], 0
    for m in re.finditer(rb"stream\r?\n(.*?)\r?\nendstream", pdf_bytes, re.S):
        try:
            s = zlib.decompress(m.group(1)).decode("latin-1")
        except zlib.error:
            continue
        total += len(re.findall(r"/\w+ [\d.]+ Tf", s))
        for b in re.finditer(r"([-\d.]+) ([-\d.]+) ([-\d.]+) ([-\d.]+) [-\d.]+ [-\d.]+ cm\s*"
                             r"BT(.*?)ET", s, re.S):
            a, b_, c, d = (float(x) for x in b.groups()[:4])
            scale = np.sqrt(abs(a * d - b_ * c))
            sizes += [float(x) * scale for x in re.findall(r"/\w+ ([\d.]+) Tf", b.group(5))]
    return sizes, total


def test_every_printed_label_is_at_least_6_pt(written_report):
    rep, files = written_report
    sizes, total = _printed_font_sizes(files.pdf.read_bytes())
    assert len(sizes) == total > 1000  # every text of the pages and figures
    assert min(sizes) >= 6.0
    # the figures are printed at their own point sizes: the smallest label of each figure
    from matplotlib.text import Text

    for f in rep.figures:
        labels = [t for t in f.figure.findobj(Text) if t.get_visible() and t.get_text()]
        assert labels and min(t.get_fontsize() for t in labels) >= 6.0, f.name
    errfun = next(f for f in rep.figures if f.name == "error-functions").figure
    assert tuple(errfun.get_size_inches()) == (11.0, 7.0)  # fits A4 landscape unscaled
    ticks = [t.get_fontsize() for ax in errfun.axes for t in ax.get_xticklabels()]
    assert min(ticks) == 6.5  # the 5 pt tick labels of the issue


def test_units_spelled_micro_and_no_internal_seed_names(customer, raw_text):
    rep, files = customer
    html = re.sub(r'src="data:[^"]*"', "", files.html.read_text(encoding="utf-8"))
    html = unescape(html)
    for text in (raw_text, html):
        assert ASCII_UNIT.findall(text) == []
        assert re.search(r"seed\s+00", text, re.I) is None
    assert "µm" in raw_text and "µrad" in raw_text
    # the identification's own messages (written with ASCII units) reach the PDF as µm
    ident = next(s for s in rep.sections if s.id == "identifiability")
    assert any("µm" in w for w in ident.warnings)
    # a References section with the full citations instead
    refs = rep.sections[-1]
    assert refs.id == "references"
    # the entries the report cites, numbered in REFERENCES' order (this report of linear
    # tests and diagonals cites neither ASME B5.54 nor the five-axis papers)
    listed = [p.split("] ", 1)[1] for p in refs.paragraphs]
    assert [p.split("]")[0] for p in refs.paragraphs] == [f"[{i}" for i in
                                                          range(1, len(listed) + 1)]
    assert listed == [r for r in REFERENCES if r in listed]
    assert not any("Weikert" in r or "ISO 10791-6" in r for r in listed)
    text = _squeeze(raw_text)
    for needle in ("Wang, G. Liotto", "LAMDAMAP", "Soons", "Analysis of the step-diagonal test",
                   "Optodyne", "ISO 230-1:2012", "ISO 230-2:2014", "ISO 230-6:2002",
                   "JCGM 100:2008"):
        assert _squeeze(needle) in text


@pytest.mark.parametrize("given, expected", [
    ("ambiguity 1.15 -> 0.03 um RMS", "ambiguity 1.15 -> 0.03 µm RMS"),
    ("EAX 13.1 urad; scale (18 urad)", "EAX 13.1 µrad; scale (18 µrad)"),
    ("deviation [um], angle [urad], 3um", "deviation [µm], angle [µrad], 3µm"),
    ("column 'deviation_um' and um_per_mm", "column 'deviation_um' and um_per_mm"),
    ("maximum, umbrella, uradical", "maximum, umbrella, uradical"),
    ("model (Soons, seed 004); ELv (seed 002)", "model (Soons, Soons 2005); ELv (Wang, Optodyne)"),
    ("Seed 000's test, seed 000/002", "Wang & Liotto 2003's test, Wang & Liotto 2003 and "
     "Wang, Optodyne"),
    ("already 2 µm", "already 2 µm"),
])
def test_customer_text(given, expected):
    assert customer_text(given) == expected


def test_identifiability_hatches_exactly_the_undetermined_functions():
    from matplotlib.patches import Rectangle

    from volcal.plot.identifiability import identifiability_plot

    std = [np.full((5, 6), 1.0) for _ in range(3)]
    std[1][:, 4] = np.inf  # EBY without a finite uncertainty
    frac = {"EXX": 0.99, "EAX": 0.07, "EYX": 0.7, "EC0Y": 0.3}
    fig = identifiability_plot(std, np.ones(3), None, frac)
    hatched = [p.get_gid() for p in fig.findobj(Rectangle) if p.get_hatch()]
    bars = {g for g in hatched if g is not None}
    assert bars == {"EAX not determined", "EBY not determined", "EC0Y not determined"}
    assert len(hatched) == len(bars) + 1  # and the legend's key, hatched the same way
    marks = [t for t in fig.findobj(lambda a: hasattr(a, "get_text")) if t.get_text() == "n/i"]
    assert len(marks) == 3
    legend = [t.get_text() for ax in fig.axes if ax.get_legend()
              for t in ax.get_legend().get_texts()]
    assert "n/i: not determined by the data" in legend
    assert any("not determined" in t and "50" in t for t in legend)
    # without determined fractions only the non-finite one
    fig = identifiability_plot(std, np.ones(3))
    assert {p.get_gid() for p in fig.findobj(Rectangle) if p.get_hatch() and p.get_gid()} == {
        "EBY not determined"}


def test_identifiability_caption_names_the_hatching(customer):
    rep, _ = customer
    f = next(f for f in rep.figures if f.name == "identifiability")
    assert "hatched" in f.caption and "n/i" in f.caption
    hatched = [p for p in f.figure.findobj() if getattr(p, "get_hatch", lambda: None)()]
    ident = next(s for s in rep.sections if s.id == "identifiability")
    table = next(t for t in ident.tables if t.title.startswith("How far"))
    undetermined = [r[0] for r in table.rows if r[3] == "not determined"]
    assert undetermined  # the simulated design leaves the roll of X open
    # one hatched bar per undetermined function, plus the legend's key
    bars = [p for p in hatched if str(p.get_gid()).endswith("not determined")]
    assert sorted(str(p.get_gid()).split()[0] for p in bars) == sorted(undetermined)


def test_every_page_says_page_k_of_n(written_report, raw_text):
    """Each page's footer: the title and "page k of n", k = 1..n in order, n the PDF's
    page count (the text pages and the figure pages alike)."""
    rep, files = written_report
    pages = raw_text.split("\f")
    pages = [p for p in pages if p.strip()]
    n = len(pages)
    info = subprocess.run([_tool(shutil.which("pdfinfo")), str(files.pdf)], capture_output=True,
                          text=True, timeout=scaled_timeout(60))
    assert f"Pages: {n}" in " ".join(info.stdout.split()), (n, info.stdout)
    for k, page in enumerate(pages, start=1):
        assert f"page {k} of {n}" in " ".join(page.split()), (k, page[-300:])
