"""Write a report folder atomically: ``report.html``, ``report.pdf`` and ``figures/*.png``."""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from volcal.io.atomic import atomic_dir
from volcal.report.document import Report
from volcal.report.figures import png_bytes
from volcal.report.html import render_html
from volcal.report.pdf import write_pdf

__all__ = ["REPORT_FILES", "ReportFiles", "write_report", "written_files"]

REPORT_FILES = ("report.html", "report.pdf", "certificate.json", "certificate.html",
                "certificate.pdf")
"""The files a report folder holds besides ``figures/NN-<name>.png``."""


@dataclass(frozen=True)
class ReportFiles:
    """Where a report was written.

    Attributes
    ----------
    folder : Path
        The report folder.
    html : Path
        Self-contained HTML report.
    pdf : Path
        PDF report.
    figures : list of Path
        The figures as separate PNG files.
    pdf_pages : int
        Number of PDF pages.
    """

    folder: Path
    html: Path
    pdf: Path
    figures: list[Path]
    pdf_pages: int


def write_report(report: Report, folder: str | Path,
                 extra: Callable[[Path], None] | None = None) -> ReportFiles:
    """Render the report to HTML and PDF and write the folder atomically.

    The folder is built in a temporary sibling and moved into place when complete, so a
    reader never sees a half-written report and a failed run leaves the old one intact.

    Parameters
    ----------
    report : Report
        The document.
    folder : str or Path
        Output folder (replaced if it exists; check it first with
        :func:`volcal.io.paths.check_output_folder` and :func:`written_files`, which
        refuses a folder holding other files).
    extra : callable, optional
        Called with the temporary folder to add more files in the same atomic
        replacement (the certificate: :func:`volcal.report.certificate_files.write_certificate`).

    Returns
    -------
    ReportFiles
    """
    folder = Path(folder)
    names = []
    figs = report.figures
    with atomic_dir(folder) as tmp:
        # each figure drawn once, on its PDF page (in worker processes where cores are
        # spare, while this one prints the text pages and the certificate, which needs no
        # figure of the report's); its PNG is that page's figure area rasterized
        pngs: dict[int, bytes] = {}
        done: list[bool] = []

        def meanwhile() -> None:
            if extra is not None and not done:
                done.append(True)
                extra(tmp)

        pages = write_pdf(report, tmp / "report.pdf", pngs=pngs, meanwhile=meanwhile)
        meanwhile()  # if write_pdf did not call it
        for i, f in enumerate(figs):  # else (write_pdf stubbed) drawn by Agg below
            f.png = pngs.get(i) or f.png or png_bytes(f.figure)
        (tmp / "report.html").write_text(render_html(report), encoding="utf-8")
        (tmp / "figures").mkdir()
        for i, f in enumerate(figs, start=1):
            name = f"{i:02d}-{f.name}.png"
            assert f.png is not None
            (tmp / "figures" / name).write_bytes(f.png)
            names.append(name)
    return ReportFiles(folder, folder / "report.html", folder / "report.pdf",
                       [folder / "figures" / n for n in names], pages)


def written_files(folder: str | Path) -> list[str]:
    """The files of a report folder volcal wrote (:func:`volcal.io.folders.claim_folder`).

    A report folder has no manifest: its files have fixed names (:data:`REPORT_FILES`)
    and the figures are ``figures/NN-<name>.png`` (``docs/formats.md``).

    Parameters
    ----------
    folder : str or Path
        A report folder.

    Returns
    -------
    list of str
        Relative paths present in the folder that volcal writes.
    """
    folder = Path(folder)
    out = [n for n in REPORT_FILES if (folder / n).is_file()]
    if (folder / "figures").is_dir():
        out += [f"figures/{p.name}" for p in (folder / "figures").iterdir()
                if p.is_file() and re.fullmatch(r"\d{2,}-.+\.png", p.name)]
    return out
