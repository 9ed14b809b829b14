"""Figures as embedded images: PNG bytes and ``data:`` URIs for a self-contained HTML file."""

from __future__ import annotations

import base64
import io

from matplotlib.figure import Figure

__all__ = ["png_bytes", "png_data_uri"]

PNG_DPI = 110
"""Resolution of the embedded PNG images [dots per inch]."""


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
    """
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, metadata={"Software": None})
    return buf.getvalue()


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
