"""Reports written with blank figures, for the tests that check what a report evaluates,
says or where it is written, not how its figures are drawn (the fixture ``blank_figures``).

Drawing a report's figures is most of its cost: for the small simulated session of
tests/report (8 figures) about 8 of its 10 s of CPU, each figure drawn once as PNG and once
as a vector page of the PDF (benchmarks/README.md, "make test time"). The figures
themselves are checked where they are drawn for real: tests/report/test_report_render.py,
test_report_pdf.py, test_report_customer_pdf.py and test_report_browser.py (one shared
rendering, ``report_fixtures.written_report``), test_report_cli.py (``volcal report`` and
``volcal demo``), the walkthrough of docs/python.md (tests/test_python_docs.py) and the
other end-to-end tests that do not ask for this fixture.

With the fixture, :func:`volcal.report.writer.write_report` (the one writer behind
``volcal report`` and ``Calibration.report``, imported when called) gets each figure swapped
for an empty one of the same size, just before it writes: everything else is written as
always, by the real code, from the real document (evaluation, sections, tables, captions,
figure names, the certificate): report.html with one ``<img>`` per figure, report.pdf
with one page per figure, ``figures/NN-<name>.png``, the folder replaced atomically.
"""

from __future__ import annotations

import pytest

__all__ = ["blank_figures", "blank_figure"]


def blank_figure(fig):
    """An empty figure (no axes) of the size and layout engine of ``fig``, on an Agg canvas."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    out = Figure(figsize=tuple(fig.get_size_inches()), layout="constrained")
    FigureCanvasAgg(out)
    return out


@pytest.fixture
def blank_figures(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Write every report of the test with blank figures (see the module); the names of
    the figures swapped, in the order written, for a test that wants to check them."""
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
