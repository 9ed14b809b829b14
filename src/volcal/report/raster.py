"""PDF pages as PNG images and pages put together into one PDF, with PDFium.

A report's figure is drawn once, as vector graphics on its PDF page
(:mod:`volcal.report.pdf`); the PNG of the HTML report and the figures folder is that
page's figure area rasterized by PDFium (Google's PDF renderer, through ``pypdfium2``),
about 40 ms a page at 200 dpi instead of a second drawing by matplotlib (0.3-0.5 s a
figure). The figure pages, drawn in worker processes as single-page PDFs, are put into
the report's PDF with PDFium's page import (``FPDF_ImportPages``: each page's content
stream and resources copied as they are).

References
----------
PDFium, https://pdfium.googlesource.com/pdfium/ (``fpdf_ppo.h``: ``FPDF_ImportPages``;
``fpdfview.h``: ``FPDF_RenderPageBitmap``); pypdfium2, https://pypdfium2.readthedocs.io.
"""

from __future__ import annotations

import io
from collections.abc import Sequence

__all__ = ["insert_pages", "page_png"]


def page_png(pdf: bytes, box: tuple[float, float, float, float], dpi: float,
             compression: int) -> bytes:
    """The part ``box`` of the first page of a PDF as a PNG image.

    Parameters
    ----------
    pdf : bytes
        A PDF file.
    box : tuple of float
        ``(x0, y0, x1, y1)``: the part of the page drawn, from its lower left corner [pt].
    dpi : float
        Resolution [dots per inch].
    compression : int
        zlib level of the PNG (0-9).

    Returns
    -------
    bytes
        PNG (RGB, white background), ``(x1 - x0) * dpi / 72`` pixels wide, rounded.
    """
    import pypdfium2 as pdfium

    doc = pdfium.PdfDocument(pdf)
    try:
        page = doc[0]
        w, h = page.get_size()
        x0, y0, x1, y1 = box
        crop = (max(0.0, x0), max(0.0, y0), max(0.0, w - x1), max(0.0, h - y1))
        bitmap = page.render(scale=dpi / 72.0, crop=crop)
        image = bitmap.to_pil()
        out = io.BytesIO()
        image.save(out, format="png", compress_level=compression, dpi=(dpi, dpi))
        bitmap.close()
        page.close()
    finally:
        doc.close()
    return out.getvalue()


def insert_pages(main: bytes, pages: Sequence[tuple[int, bytes]]) -> bytes:
    """A PDF with single-page PDFs put in at their places.

    Parameters
    ----------
    main : bytes
        The PDF holding the other pages, in order (its document information, title and
        creator, is kept).
    pages : sequence of (int, bytes)
        ``(index, pdf)``: the first page of ``pdf`` becomes page ``index`` (from 0) of the
        result.

    Returns
    -------
    bytes
        The whole PDF.
    """
    if not pages:
        return main
    import pypdfium2 as pdfium

    doc = pdfium.PdfDocument(main)
    sources = []
    try:
        for index, data in sorted(pages, key=lambda p: p[0]):
            src = pdfium.PdfDocument(data)
            sources.append(src)
            doc.import_pages(src, [0], index)
        out = io.BytesIO()
        doc.save(out)
    finally:
        for src in sources:
            src.close()
        doc.close()
    return out.getvalue()
