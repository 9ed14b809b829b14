"""Rendering the report fast without changing it (issue 31): each figure drawn once (its
PDF page; the PNG is that page rasterized), figure pages drawn in worker processes the same
as here, the figures' data untouched by the rendering, the PDF's text wrapped as by the
greedy rule, heavy artists rasterized at RASTER_DPI."""

import base64
import os
import re
import shutil
import struct
import subprocess
import time

import numpy as np
import pytest
import report_fixtures as _fx

from timing import scaled_timeout
from volcal.plot._figure import new_figure
from volcal.report import figures as F
from volcal.report.document import FigureItem, Report, Section, Table
from volcal.report.pdf import RASTER_DPI, RASTER_POINTS, _Measure, write_pdf

# pytest fixtures shared by the report tests (see report_fixtures.py)
identified = _fx.identified
small_session = _fx.small_session
written_report = _fx.written_report
written_report_drawing = _fx.written_report_drawing
figure_data = _fx.figure_data


def test_rendering_draws_each_figure_once_and_keeps_its_data(written_report,
                                                              written_report_drawing):
    """Each figure drawn once, on its PDF page; its PNG (HTML, figures folder) is that
    page's figure area rasterized, not a second drawing.

    The report is the one shared by the report tests (report_fixtures.written_report,
    the same build_report of the same session this test built and wrote for itself):
    it is written with its drawings counted, in this process, and this test reads the
    record (report_fixtures.written_report_drawing)."""
    built, files = written_report
    drawing = written_report_drawing
    before, drawn = drawing.before, drawing.drawn
    assert all(before) and len(built.figures) >= 6
    for f in built.figures:
        assert drawn.get((id(f.figure), "pdf")) == 1, f.name  # its PDF page
        assert (id(f.figure), "png") not in drawn, f.name  # no Agg drawing
    assert len(files.figures) == len(built.figures)
    assert drawing.after == before
    # the figures are left as built: their own size, their layout engine, Agg canvas
    for engine, canvas, rasterized in drawing.left:
        assert engine
        assert canvas == "FigureCanvasAgg"
        assert not rasterized
    # the PNGs: the figure's area of its page at PNG_DPI, in the HTML as in the folder
    html = files.html.read_text()
    for f, path in zip(built.figures, files.figures, strict=True):
        png = path.read_bytes()
        assert png.startswith(b"\x89PNG") and f.png == png
        assert base64.b64encode(png).decode() in html
        w, h = struct.unpack(">II", png[16:24])
        # at most the page's width less its margins, plus 6 pt of white each side
        assert 1000 < w <= round((11.69 - 0.9 + 12 / 72) * F.PNG_DPI) + 2 and 300 < h < w
    assert _pdf_pages(files.pdf) == files.pdf_pages


def _pdf_pages(pdf) -> int:
    import pypdfium2 as pdfium

    doc = pdfium.PdfDocument(str(pdf))
    try:
        return len(doc)
    finally:
        doc.close()


def _pdf_text(pdf) -> str:
    tool = shutil.which("pdftotext")
    if tool is None:
        pytest.skip("pdftotext is not installed (poppler-utils)")
    return subprocess.run([tool, "-layout", str(pdf), "-"], capture_output=True, text=True,
                          timeout=scaled_timeout(60), check=True).stdout


def test_figure_pages_drawn_in_workers_equal_the_ones_drawn_here(identified, tmp_path):
    """Workers draw the figure pages the same as this process: the same PNGs, the same
    PDF text page by page (footers "page k of n" included). The second figure is the
    error functions' layout with one component column (_error_functions_like): what a
    worker does with a figure does not depend on its number of panels; 21 panels cost
    4 s more per run."""
    from volcal.plot import linear_deviation_plot

    s, r = identified
    lin = next(m for m in s.measurements if m.kind == "linear")

    def report():
        figs = [linear_deviation_plot(lin), _error_functions_like(r.errors),
                linear_deviation_plot(lin)]
        items = [FigureItem(f, f"caption {k}", f"f{k}") for k, f in enumerate(figs)]
        return Report("parallel", [Section("a", "A", paragraphs=["one"], figures=items[:2]),
                                   Section("b", "B", tables=[Table(["x"], [["1"]])],
                                           figures=items[2:])]), figs

    out = {}
    for workers in (2, 0):
        rep, figs = report()
        data = [figure_data(f) for f in figs]
        pngs: dict = {}
        pages = write_pdf(rep, tmp_path / f"w{workers}.pdf", pngs=pngs, workers=workers)
        assert [figure_data(f) for f in figs] == data
        # the title page's "Created <date> <hh:mm> UTC": the two PDFs may straddle a
        # minute (failed once so, session 16)
        out[workers] = (pages, [pngs[i] for i in range(3)],
                        re.sub(r"Created \d{4}-\d\d-\d\d \d\d:\d\d UTC", "Created",
                               _pdf_text(tmp_path / f"w{workers}.pdf")))
    assert out[2] == out[0]
    pages, pngs, text = out[0]
    assert pages == 5 and pngs[0] == pngs[2] and pngs[0] != pngs[1]
    pdf_pages = text.split("\f")[:5]
    assert [f"page {k} of 5" in p for k, p in enumerate(pdf_pages, start=1)] == [True] * 5
    # the figure pages at their places: A's two figures after its text, B's after B's table
    assert ["Figure 1: caption 0" in pdf_pages[1], "Figure 2: caption 1" in pdf_pages[2],
            "2. B" in pdf_pages[3], "Figure 3: caption 2" in pdf_pages[4]] == [True] * 4


def _small_figures():
    out = []
    for k in (1, 2):
        fig = new_figure(4.0, 3.0)
        ax = fig.add_subplot()
        ax.plot(np.arange(10.0), np.arange(10.0) ** k)
        ax.set_xlabel("X [mm]")
        out.append(fig)
    return out


def test_a_worker_that_dies_leaves_its_figures_to_this_process():
    parent = os.getpid()

    def draw(fig):
        if os.getpid() != parent:
            os._exit(3)  # a worker killed while it draws
        return F.png_bytes(fig)

    drawing = F.draw_all(_small_figures(), draw, workers=1)
    assert drawing.parallel
    expected = [F.png_bytes(f) for f in _small_figures()]
    assert drawing.result() == expected and expected[0] != expected[1]


def test_a_worker_that_fails_leaves_its_figure_to_this_process():
    parent = os.getpid()

    def draw(fig):
        if os.getpid() != parent:
            raise RuntimeError("worker")
        return F.png_bytes(fig)

    drawing = F.draw_all(_small_figures(), draw, workers=1)
    expected = [F.png_bytes(f) for f in _small_figures()]
    assert drawing.result() == expected


def test_each_figure_drawn_by_one_process_whichever_is_free(tmp_path):
    """This process and the worker take the figures in turn from one counter: both draw,
    none twice, none lost, the same PNGs as a drawing without workers.

    How many each process takes depends on the load, so the test counts the drawings,
    not their split."""
    parent = os.getpid()
    here: list[int] = []
    log = tmp_path / "worker.log"

    def draw(fig):
        if os.getpid() == parent:
            here.append(id(fig))
        else:
            time.sleep(scaled_timeout(1.0))  # a slow worker
            with open(log, "a") as f:
                f.write("drawn\n")
        return F.png_bytes(fig)

    figs = [g for _ in range(3) for g in _small_figures()]  # six figures, two kinds
    drawing = F.draw_all(figs, draw, workers=1)
    assert drawing.parallel
    pngs = drawing.result()
    by_worker = len(log.read_text().splitlines()) if log.exists() else 0
    assert here and by_worker  # both drew
    assert len(here) + by_worker == len(figs)  # none twice, none lost
    expected = [F.png_bytes(f) for f in _small_figures()] * 3
    assert pngs == expected and expected[0] != expected[1]


def _error_functions_like(errors):
    """A lighter figure built as error_functions_plot builds its 3 x 7 grid: per axis one
    component panel (two-line title, legend in the first) instead of six, and the
    squareness bars in a last column spanning the rows, the suptitle above.

    The spanning column is what a layout started from the page's positions shifts (a
    figure without it, e.g. the diagonals' fits, gives the same PNG even when the page
    does not put the axes back): kept, it tests what the 21 panels test, at 1.5 s
    instead of 5.4 s for the three PNGs and the page."""
    from volcal.plot.errorfunctions import FIGURE_SIZE

    fig = new_figure(*FIGURE_SIZE)
    gs = fig.add_gridspec(3, 2)
    for a in range(3):
        ax = fig.add_subplot(gs[a, 0])
        ax.plot(errors.nodes[a], errors.values[a][:, 0], label="estimate")
        ax.set_title(f"E{'XYZ'[a]}{'XYZ'[a]} [µm]\npositioning", fontsize=7.5)
        ax.tick_params(labelsize=6.5)
        ax.grid(True, alpha=0.3)
        ax.set_xlabel(f"{'XYZ'[a]} [mm]", fontsize=7.0)
        if a == 0:
            ax.legend(fontsize=6.5)
    ax = fig.add_subplot(gs[:, 1])
    ax.bar(np.arange(3), errors.squareness, label="estimate")
    ax.legend(fontsize=6.5)
    fig.suptitle(f"{errors.name}: error functions", fontsize=10.0)
    return fig


def test_a_png_drawn_after_the_pdf_page_is_the_same(identified, tmp_path):
    """png_bytes (a figure outside a report, at its own size) is not changed by the
    figure's PDF page: the page lays the figure out again and puts it back as built.
    (The error functions' layout with one component column: _error_functions_like.)"""
    _, r = identified
    first = F.png_bytes(_error_functions_like(r.errors))
    fig = _error_functions_like(r.errors)
    write_pdf(Report("t", [Section("s", "S", figures=[FigureItem(fig, "c", "e")])]),
              tmp_path / "t.pdf", workers=0)
    assert F.png_bytes(fig) == first  # laid out from where it was built, not from the page
    fig.__dict__.pop("_volcal_png", None)
    assert F.png_bytes(fig) == first  # and again


def test_draw_workers_from_the_environment(monkeypatch):
    monkeypatch.setenv(F.WORKERS_ENV, "3")
    assert F.draw_workers(8) == 3
    assert F.draw_workers(2) == 2  # never more than the figures
    monkeypatch.setenv(F.WORKERS_ENV, "0")
    assert F.draw_workers(8) == 0
    monkeypatch.setenv(F.WORKERS_ENV, "two")
    with pytest.raises(ValueError, match="VOLCAL_REPORT_WORKERS='two'"):
        F.draw_workers(8)
    monkeypatch.delenv(F.WORKERS_ENV)
    assert 0 <= F.draw_workers(8) <= 8


@pytest.mark.parametrize(("idle", "cores", "load", "expected"), [
    (1.0, 2, 1.0, 1),  # one core idle while the report worked: a worker (load average high
                       # from the run before, not counted)
    (0.6, 2, 0.0, 1),
    (0.3, 2, 0.0, 0),  # both cores mostly busy: none
    (0.0, 2, 0.0, 0),
    (3.0, 4, 0.0, 3),
    (None, 2, 0.4, 1),  # no /proc/stat: the load average
    (None, 2, 0.9, 0),
])
def test_draw_workers_from_the_idle_cores(monkeypatch, idle, cores, load, expected):
    monkeypatch.delenv(F.WORKERS_ENV, raising=False)
    monkeypatch.setattr(F, "spare_cores", lambda: idle)
    monkeypatch.setattr(F.os, "cpu_count", lambda: cores)
    monkeypatch.setattr(F.os, "getloadavg", lambda: (load, load, load))
    assert F.draw_workers(8) == expected


def test_spare_cores_from_proc_stat(monkeypatch):
    """Idle time over the window since the module was imported, in cores."""
    times = iter([(100.0, 400.0)])
    monkeypatch.setattr(F, "_SINCE", ((40.0, 200.0), time.monotonic() - 1.0))
    monkeypatch.setattr(F, "_cpu_times", lambda: next(times))
    monkeypatch.setattr(F.os, "cpu_count", lambda: 2)
    assert F.spare_cores() == pytest.approx(60.0 / 200.0 * 2)
    monkeypatch.setattr(F, "_SINCE", ((40.0, 200.0), time.monotonic()))  # too short
    monkeypatch.setattr(F, "_cpu_times", lambda: (100.0, 400.0))
    assert F.spare_cores() is None
    monkeypatch.setattr(F, "_SINCE", (None, 0.0))
    assert F.spare_cores() is None
    F.watch_cores()  # the window starts now: too short yet
    assert F._SINCE[0] == (100.0, 400.0) and F.spare_cores() is None


def _greedy(m: _Measure, text: str, width: float, size: float, weight: str = "normal"):
    """The greedy rule as it was written first: every candidate line measured whole."""
    lines = []
    for para in text.split("\n"):
        line = ""
        for word in para.split():
            cand = f"{line} {word}" if line else word
            if m.width(cand, size, weight) <= width:
                line = cand
                continue
            if line:
                lines.append(line)
            line = ""
            while m.width(word, size, weight) > width and len(word) > 1:
                k = len(word) - 1
                while k > 1 and m.width(word[:k], size, weight) > width:
                    k -= 1
                lines.append(word[:k])
                word = word[k:]
            line = word
        lines.append(line)
    return lines or [""]


def test_wrap_breaks_the_lines_of_the_greedy_rule(written_report):
    """The texts of the shared report (its paragraphs, warnings and table cells, as built:
    writing the report does not change its document) and hard cases."""
    built = written_report[0]
    m = _Measure()
    paragraphs = [p for s in built.sections for p in s.paragraphs + s.warnings]
    cells = sorted({c for s in built.sections for t in s.tables for r in t.rows for c in r})
    hard = ["x" * 60 + "Y" * 60 + "z" * 60, "a " + "W" * 50 + " b c", "", "one\n\ntwo three",
            " ".join(f"word{i:03d}" for i in range(90))]
    n = 0
    for texts, size, weight, width in ((paragraphs + hard, 9.5, "normal", 480.0),
                                       (cells + hard, 7.0, "bold", 60.0)):
        for t in texts:
            assert m.wrap(t, width, size, weight) == _greedy(m, t, width, size, weight)
            n += 1
    assert n > 300


def _pdfimages(pdf):
    tool = shutil.which("pdfimages")
    if tool is None:
        pytest.skip("pdfimages is not installed (poppler-utils)")
    r = subprocess.run([tool, "-list", str(pdf)], capture_output=True, text=True,
                       timeout=scaled_timeout(60))
    assert r.returncode == 0, r.stderr
    return [ln.split() for ln in r.stdout.splitlines()[2:] if ln.strip()]


def test_heavy_artists_rasterized_inside_a_vector_figure(tmp_path):
    rng = np.random.default_rng(5)
    fig = new_figure(8.0, 5.0)
    ax = fig.add_subplot()
    dense = ax.plot(rng.normal(size=RASTER_POINTS + 500), rng.normal(size=RASTER_POINTS + 500),
                    linestyle="none", marker=".", markersize=2, gid="readings")[0]
    ax.plot([-3.0, 3.0], [-1.0, 1.0], color="tab:orange", gid="fit")
    ax.set_xlabel("along beam [mm]")
    ax.set_ylabel("deviation [µm]")
    light = new_figure(8.0, 5.0)
    light.add_subplot().plot(np.arange(RASTER_POINTS), np.zeros(RASTER_POINTS))
    rep = Report("raster test", [Section("s", "S", tables=[Table(["a"], [["1"]])],
                                         figures=[FigureItem(fig, "dense", "dense"),
                                                  FigureItem(light, "light", "light")])])
    pdf = tmp_path / "r.pdf"
    assert write_pdf(rep, pdf) == 3
    images = [c for c in _pdfimages(pdf) if c[2] == "image"]  # not their alpha masks
    assert [int(c[0]) for c in images] == [2]  # the dense figure's page only
    xppi, yppi = float(images[0][12]), float(images[0][13])
    assert xppi >= RASTER_DPI - 1 and yppi >= RASTER_DPI - 1
    text = subprocess.run([shutil.which("pdftotext"), "-layout", str(pdf), "-"],
                          capture_output=True, text=True, timeout=scaled_timeout(60)).stdout
    assert "along beam [mm]" in text and "deviation [µm]" in text  # labels stay text
    assert not dense.get_rasterized()  # the figure itself is left as it was
