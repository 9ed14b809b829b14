"""The PDF report rendered page by page with poppler's pdftoppm."""

import shutil
import subprocess

import matplotlib.image as mpimg
import numpy as np
import pytest
import report_fixtures as _fx

from timing import scaled_timeout

# pytest fixtures shared by the report tests (see report_fixtures.py)
identified = _fx.identified
small_session = _fx.small_session
written_report = _fx.written_report

PDFTOPPM = shutil.which("pdftoppm")


def _pages(pdf, tmp_path, dpi=30):
    if PDFTOPPM is None:
        pytest.skip("pdftoppm is not installed (make browser-deps installs poppler-utils)")
    r = subprocess.run([PDFTOPPM, "-r", str(dpi), "-png", str(pdf), str(tmp_path / "p")],
                       capture_output=True, text=True, timeout=scaled_timeout(120))
    assert r.returncode == 0, r.stderr
    return [mpimg.imread(p) for p in sorted(tmp_path.glob("p-*.png"))]


def test_pdf_pages_render_and_are_not_blank(written_report, tmp_path):
    rep, files = written_report
    pages = _pages(files.pdf, tmp_path)
    assert len(pages) == files.pdf_pages
    assert files.pdf_pages >= len(rep.figures) + 2  # text pages + one page per figure
    portrait = [p for p in pages if p.shape[0] > p.shape[1]]
    landscape = [p for p in pages if p.shape[0] < p.shape[1]]
    assert len(landscape) == len(rep.figures)  # one A4 landscape page per figure
    assert portrait
    for p in pages:
        gray = p[..., :3].mean(axis=2)
        assert (gray < 0.5).mean() > 0.002, "blank page"
    # A4 at 30 dpi: 248 x 351 px
    assert abs(portrait[0].shape[0] - 351) <= 2 and abs(portrait[0].shape[1] - 248) <= 2
    # figure pages carry colour (plotted lines), not just black text
    for p in landscape:
        rgb = p[..., :3]
        chroma = rgb.max(axis=2) - rgb.min(axis=2)
        assert (chroma > 0.2).mean() > 0.001


def test_pdf_text_has_the_section_titles(written_report):
    pdftotext = shutil.which("pdftotext")
    if pdftotext is None:
        pytest.skip("pdftotext is not installed (poppler-utils)")
    rep, files = written_report
    text = subprocess.run([pdftotext, "-layout", str(files.pdf), "-"], capture_output=True,
                          text=True, timeout=scaled_timeout(60)).stdout
    for i, s in enumerate(rep.sections, start=1):
        assert f"{i}. {s.title}" in text
    assert "ISO 230-2:2014 positioning parameters" in text
    assert np.sum([t in text for t in ("EXX", "EC0Y", "E_VXYZ")]) == 3
