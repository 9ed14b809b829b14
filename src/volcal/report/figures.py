"""Figures as embedded images: PNG bytes and ``data:`` URIs for a self-contained HTML file."""

from __future__ import annotations

import base64
import io

from matplotlib.figure import Figure

__all__ = ["png_bytes", "png_data_uri"]

PNG_DPI = 200
"""Resolution of the PNG images [dots per inch], the same in the HTML and the figures
folder, so that each figure is drawn once for both (the PDF draws them as vectors). At least
200 dpi, so that a figure printed from the HTML at its natural size stays sharp."""


def png_bytes(fig: Figure, dpi: int = PNG_DPI) -> bytes:
    """Render a figure to PNG.

    Parameters
    ----------
    fig : Figure
        The figure.
    dpi : int
        Resolution [dots per inch].

    Returns
    -------
    bytes
        The PNG file (no time stamp in its metadata, so equal figures give equal bytes).

    Notes
    -----
    The bytes are kept on the figure (per resolution): a report's figures are finished
    when they are rendered, and the HTML, the PDF and the figures folder share one drawing
    (drawing is most of a report's time).
    """
    cache = fig.__dict__.setdefault("_volcal_png", {})
    if dpi not in cache:
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=dpi, metadata={"Software": None})
        cache[dpi] = buf.getvalue()
    return cache[dpi]


def png_data_uri(fig: Figure, dpi: int = PNG_DPI) -> str:
    """Render a figure to a base64 ``data:image/png`` URI (RFC 2397).

    Parameters
    ----------
    fig : Figure
        The figure.
    dpi : int
        Resolution [dots per inch].

    Returns
    -------
    str
    """
    return "data:image/png;base64," + base64.b64encode(png_bytes(fig, dpi)).decode("ascii")
