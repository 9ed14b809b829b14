"""Render the calibration certificate as one self-contained HTML file.

The same sections as the PDF (:mod:`volcal.report.certificate_layout`); printed from a
browser, CSS ``@page`` margin boxes put the report id and "page n of m" on every page.
"""

from __future__ import annotations

from typing import Any

from volcal.report.certificate_layout import layout

__all__ = ["render_certificate_html"]


def render_certificate_html(doc: dict[str, Any], angle_units: str = "urad") -> str:
    """Render a ``volcal-certificate/1`` document as HTML text.

    Parameters
    ----------
    doc : dict
        The certificate (:func:`volcal.report.certificate.build_certificate`).
    angle_units : str
        ``'urad'`` or ``'arcsec'``: the printed unit of the rotary axes' results.

    Returns
    -------
    str
        A complete HTML5 document (jinja2, autoescaped).
    """
    from volcal.report.html import _ENV

    return _ENV.get_template("certificate.html.j2").render(doc=doc,
                                                               sections=layout(doc, angle_units))
