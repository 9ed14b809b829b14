"""Reports written with less drawing, for the tests that check what a report evaluates,
says or where it is written, not how it is drawn: the fixtures ``blank_figures`` and
``stub_pdfs``.

Drawing is most of a report's cost. For the small simulated session of tests/report
(8 figures; main of 2026-11-26 with the drawing cache) building the document takes about
2.3 s of CPU, the figures' PNGs 3.5 s and the PDF 3.6 s (its figure pages, and its text
pages: every table cell measured and drawn by matplotlib); a certificate's PDF takes
seconds more (benchmarks/README.md, "make test time"). What is drawn is checked where it
is drawn for real: tests/report/test_report_render.py, test_report_pdf.py,
test_report_customer_pdf.py and test_report_browser.py (one shared rendering,
``report_fixtures.written_report``), test_report_cli.py (``volcal demo``; its ``volcal
report`` process uses ``use_blank_figures``), test_certificate*.py (the certificate's PDF
read back), tests/standards/test_incomplete.py and tests/cli/test_missed_capture_flow.py (reports of
partly measured sessions and missed readings) and every other test that asks for neither
fixture.

``blank_figures``: :func:`volcal.report.writer.write_report` (the one writer behind
``volcal report`` and ``Calibration.report``, imported when called) gets each figure
swapped for an empty one of the same size just before it writes; everything else is written
as always, by the real code, from the real document (evaluation, sections, tables,
captions, figure names, the certificate): report.html with one ``<img>`` per figure,
report.pdf with one page per figure, ``figures/NN-<name>.png``, the folder replaced
atomically.

``stub_pdfs``: report.pdf and certificate.pdf are written as a stub (:data:`STUB_PDF`, one
page), where a test reads neither; the HTML, the JSON, the figures and the folder are
written as always.
"""

from __future__ import annotations

from pathlib import Path

import pytest

__all__ = ["STUB_PDF", "blank_figure", "blank_figures", "stub_pdfs", "use_blank_figures",
           "use_stub_pdfs"]

STUB_PDF = b"%PDF-1.4\n% stub: tests/report_stubs.py\n"
"""What ``stub_pdfs`` writes in place of report.pdf and certificate.pdf (one page, as
counted)."""


def blank_figure(fig):
    """An empty figure (no axes) of the size and layout engine of ``fig``, on an Agg canvas."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    out = Figure(figsize=tuple(fig.get_size_inches()), layout="constrained")
    FigureCanvasAgg(out)
    return out


def use_blank_figures(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Write every report with blank figures while ``monkeypatch`` holds (see the module);
    the names of the figures swapped, in the order written."""
    import volcal.report.writer as writer

    real = writer.write_report
    swapped: list[str] = []

    def write_report(report, folder, extra=None):
        for item in report.figures:
            item.figure = blank_figure(item.figure)
            swapped.append(item.name)
        return real(report, folder, extra)

    monkeypatch.setattr(writer, "write_report", write_report)
    return swapped


def use_stub_pdfs(monkeypatch: pytest.MonkeyPatch) -> list[Path]:
    """Write report.pdf and certificate.pdf as :data:`STUB_PDF` while ``monkeypatch``
    holds (see the module); the paths stubbed, in the order written."""
    import volcal.report.certificate_pdf as certificate_pdf
    import volcal.report.writer as writer

    stubbed: list[Path] = []

    def write_pdf(doc, path, *options, **keywords) -> int:  # any further argument ignored
        Path(path).write_bytes(STUB_PDF)
        stubbed.append(Path(path))
        return 1

    monkeypatch.setattr(writer, "write_pdf", write_pdf)
    monkeypatch.setattr(certificate_pdf, "write_certificate_pdf", write_pdf)
    return stubbed


@pytest.fixture
def blank_figures(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The test's reports with blank figures (:func:`use_blank_figures`)."""
    return use_blank_figures(monkeypatch)


@pytest.fixture
def stub_pdfs(monkeypatch: pytest.MonkeyPatch) -> list[Path]:
    """The test's report.pdf and certificate.pdf stubbed (:func:`use_stub_pdfs`)."""
    return use_stub_pdfs(monkeypatch)
