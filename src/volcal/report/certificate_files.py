"""Write the certificate files: ``certificate.pdf``, ``certificate.html``, ``certificate.json``.

``certificate.json`` is the machine-readable certificate, format ``volcal-certificate/1``;
its JSON Schema (draft 2020-12) ships with the package
(``volcal/report/schemas/volcal-certificate-1.schema.json``, :func:`schema`) and every
field is described in ``docs/certificate.md``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path
from typing import Any

__all__ = ["CertificateFiles", "SCHEMA_FILE", "schema", "write_certificate"]

SCHEMA_FILE = "volcal-certificate-1.schema.json"
"""File name of the JSON Schema of ``volcal-certificate/1`` in ``volcal.report.schemas``."""


@dataclass(frozen=True)
class CertificateFiles:
    """Where a certificate was written.

    Attributes
    ----------
    pdf, html, json : Path
        The three files.
    pdf_pages : int
        Number of PDF pages.
    """

    pdf: Path
    html: Path
    json: Path
    pdf_pages: int


def schema() -> dict[str, Any]:
    """The JSON Schema of ``volcal-certificate/1`` (a dict, draft 2020-12)."""
    text = files("volcal.report").joinpath("schemas", SCHEMA_FILE).read_text(encoding="utf-8")
    return json.loads(text)


def write_certificate(doc: dict[str, Any], folder: str | Path, angle_units: str = "urad"
                      ) -> CertificateFiles:
    """Write the certificate into a folder (the caller makes the folder atomic).

    Parameters
    ----------
    doc : dict
        The certificate (:func:`volcal.report.certificate.build_certificate`).
    folder : str or Path
        Existing folder (normally the temporary report folder of
        :func:`volcal.report.writer.write_report`).
    angle_units : str
        ``'urad'`` or ``'arcsec'``: the printed unit of the rotary axes' results in the
        HTML and PDF (``certificate.json`` keeps µrad, its ``unit``).

    Returns
    -------
    CertificateFiles
    """
    from volcal.report.certificate_html import render_certificate_html
    from volcal.report.certificate_pdf import write_certificate_pdf

    folder = Path(folder)
    js = folder / "certificate.json"
    js.write_text(json.dumps(doc, indent=2, ensure_ascii=False, allow_nan=False) + "\n",
                  encoding="utf-8")
    html = folder / "certificate.html"
    html.write_text(render_certificate_html(doc, angle_units), encoding="utf-8")
    pdf = folder / "certificate.pdf"
    pages = write_certificate_pdf(doc, pdf, angle_units)
    return CertificateFiles(pdf, html, js, pages)
