"""Figures as embedded images: PNG bytes and ``data:`` URIs for a self-contained HTML file.

Each figure is drawn once as PNG for the HTML and the figures folder (:func:`png_bytes`)
and once as vector graphics for the PDF (:mod:`volcal.report.pdf`). The PNGs of figures
independent of each other are drawn in parallel while the PDF is printed, where the
machine has cores to spare (:func:`draw_pngs`, :func:`draw_workers`).
"""

from __future__ import annotations

import base64
import io
import math
import multiprocessing
import os
import warnings
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from volcal.report.drawcache import cached_drawing

__all__ = ["PNG_COMPRESSION", "PNG_DPI", "WORKERS_ENV", "PngDrawing", "draw_pngs",
           "draw_workers", "kept_layout", "png_bytes", "png_data_uri"]

PNG_DPI = 200
"""Resolution of the PNG images [dots per inch], the same in the HTML and the figures
folder, so that each figure is drawn once for both (the PDF draws them as vectors). At least
200 dpi, so that a figure printed from the HTML at its natural size stays sharp."""

PNG_COMPRESSION = 3
"""zlib level of the PNG images (0-9): 3 deflates the report's 8 figures in about two thirds
of the time of PIL's default 6 (0.53 s instead of 0.80 s), for files about a tenth larger;
the pixels are the same."""

WORKERS_ENV = "VOLCAL_REPORT_WORKERS"
"""Environment variable: number of processes drawing a report's PNG figures beside the one
printing the PDF (``0``: all in one process); by default the cores the machine has to spare
(:func:`draw_workers`)."""

_CACHE = "_volcal_png"


def _cache(fig: Figure) -> dict[int, bytes]:
    cache: dict[int, bytes] = fig.__dict__.setdefault(_CACHE, {})
    return cache


@contextmanager
def kept_layout(fig: Figure) -> Iterator[None]:
    """Put the figure's axes back where they were when the block ends.

    A layout engine (constrained layout) starts from where the axes are: a figure laid out
    once (as a PNG, on its PDF page) is laid out a hair differently the next time. Each
    drawing of a report's figures starts from the figure as built, so its PNG is the same
    whether it is drawn before or after the PDF page, here or in a worker process.

    Parameters
    ----------
    fig : Figure
        The figure.
    """
    placed = [(ax, ax.get_position(original=True).frozen(), ax.get_position().frozen())
              for ax in fig.axes]
    try:
        yield
    finally:
        for ax, original, active in placed:  # not set_position: it takes ax out of layout
            ax._set_position(original, which="original")  # type: ignore[attr-defined]
            ax._set_position(active, which="active")  # type: ignore[attr-defined]


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
    The figure is laid out (its layout engine, constrained layout for volcal's figures)
    and drawn in one pass on its Agg canvas, from where it was built (:func:`kept_layout`).
    ``Figure.savefig`` would lay it out in a drawing pass of its own before the drawing it
    saves, drawing every figure twice; the pixels are the same
    (``tests/report/test_report_render.py``), deflated at zlib level
    :data:`PNG_COMPRESSION`. The bytes are kept on the
    figure (per resolution): a report's figures are finished when they are rendered, and
    the HTML and the figures folder share one drawing.
    """
    cache = _cache(fig)
    if dpi not in cache:
        canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
        buf = io.BytesIO()
        old = fig.dpi
        try:
            fig.dpi = dpi
            canvas._is_saving = True  # type: ignore[attr-defined]  # as savefig does
            with cached_drawing(), kept_layout(fig):
                canvas.print_png(buf, metadata={"Software": None},
                                 pil_kwargs={"compress_level": PNG_COMPRESSION})
        finally:
            canvas._is_saving = False  # type: ignore[attr-defined]
            fig.dpi = old
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


def draw_workers(jobs: int, busy: int = 1) -> int:
    """How many worker processes may draw figures now.

    Parameters
    ----------
    jobs : int
        Figures to draw.
    busy : int
        Processes of this program that stay busy meanwhile (the one printing the PDF).

    Returns
    -------
    int
        :data:`WORKERS_ENV` when set; else the cores the machine has to spare, its core
        count less its load (the one-minute load average, :func:`os.getloadavg`) less
        ``busy``, rounded, at most ``jobs``; 0 (draw in this process) where the load or
        the ``fork`` start method is not available.

    Raises
    ------
    ValueError
        If :data:`WORKERS_ENV` is not a whole number >= 0.
    """
    given = os.environ.get(WORKERS_ENV, "").strip()
    if given:
        if not given.isdigit():
            raise ValueError(f"{WORKERS_ENV}={given!r}: expected a whole number >= 0")
        n = int(given)
    else:
        try:
            load = os.getloadavg()[0]
        except (AttributeError, OSError):
            return 0
        n = math.floor((os.cpu_count() or 1) - load - busy + 0.5)
    if "fork" not in multiprocessing.get_all_start_methods():
        return 0
    return max(0, min(jobs, n))


_TASK: tuple[Callable[[Figure], bytes], Sequence[Figure]] | None = None
"""What the forked workers draw: set before the fork, inherited by the children."""


def _draw_one(i: int) -> bytes:
    assert _TASK is not None
    draw, figs = _TASK
    return draw(figs[i])


class PngDrawing:
    """PNGs of figures being drawn, in worker processes or (none) on :meth:`result`.

    Parameters
    ----------
    figs : sequence of Figure
        The figures.
    draw : callable
        Draws one figure to PNG bytes (:func:`png_bytes`).
    workers : int
        Worker processes (0: the figures are drawn in this process by :meth:`result`).
    """

    def __init__(self, figs: Sequence[Figure], draw: Callable[[Figure], bytes],
                 workers: int) -> None:
        global _TASK
        self.figs, self.draw, self.workers = list(figs), draw, workers
        self._pool: ProcessPoolExecutor | None = None
        self._futures: list[Future[bytes]] = []
        self._order: list[int] = []
        if workers and self.figs:
            _TASK = (draw, self.figs)
            with warnings.catch_warnings():  # a fork beside the console's status thread:
                warnings.simplefilter("ignore", DeprecationWarning)  # the child only draws
                self._pool = ProcessPoolExecutor(
                    workers, mp_context=multiprocessing.get_context("fork"))
                # the largest figures first, so that the workers finish together; the
                # workers are forked at the first submission, inheriting the figures
                order = sorted(range(len(self.figs)), key=lambda i: -len(self.figs[i].axes))
                futures = {i: self._pool.submit(_draw_one, i) for i in order}
            self._order = order
            self._futures = [futures[i] for i in range(len(self.figs))]

    def result(self) -> list[bytes]:
        """The PNG of every figure, in the order given (also kept on each figure).

        Returns
        -------
        list of bytes

        Notes
        -----
        The figures no worker has started yet are drawn in this process (the last queued
        first) while the workers finish theirs, so that the two halves of the work end
        about together whatever the load. A worker that dies (killed, out of memory)
        does not hang the report: its figures are drawn in this process instead.
        """
        global _TASK
        if self._pool is None:
            return [self.draw(f) for f in self.figs]
        here: dict[int, bytes] = {}
        out: list[bytes] = []
        try:
            # the figures no worker has started yet are drawn here, the last queued first,
            # while the workers draw theirs: both processes finish about together
            while True:
                pending = [i for i in self._order if i not in here
                           and not self._futures[i].running() and not self._futures[i].done()]
                if not pending:
                    break
                if self._futures[pending[-1]].cancel():  # else a worker took it meanwhile
                    here[pending[-1]] = self.draw(self.figs[pending[-1]])
            for i, (fig, future) in enumerate(zip(self.figs, self._futures, strict=True)):
                if i in here:
                    out.append(here[i])
                    continue
                try:
                    data = future.result()
                except BrokenProcessPool:
                    data = self.draw(fig)
                else:
                    if self.draw is png_bytes:  # what png_bytes gives from now on
                        _cache(fig)[PNG_DPI] = data
                out.append(data)
        finally:
            self._pool.shutdown(cancel_futures=True)
            _TASK = None
        return out

    def close(self) -> None:
        """Stop the workers (after :meth:`result`, or when the report failed meanwhile)."""
        global _TASK
        if self._pool is not None:
            self._pool.shutdown(cancel_futures=True)
            _TASK = None

    @property
    def parallel(self) -> bool:
        """Whether worker processes draw the figures."""
        return self._pool is not None


def draw_pngs(figs: Sequence[Figure], draw: Callable[[Figure], bytes] = png_bytes,
              workers: int | None = None) -> PngDrawing:
    """Start drawing the PNGs of figures independent of each other.

    With workers, the figures are drawn in processes forked now (each one inherits the
    figures as they are, so the drawing does not depend on what this process does with
    them meanwhile) while this process goes on (printing the PDF); without, they are
    drawn here, first, by :meth:`PngDrawing.result`: call it before the figures are used
    for anything else, so that both ways give the same bytes.

    Parameters
    ----------
    figs : sequence of Figure
        The figures (matplotlib's object-oriented API on Agg canvases: no global state).
    draw : callable
        Draws one figure to PNG bytes at :data:`PNG_DPI`.
    workers : int, optional
        Worker processes; :func:`draw_workers` by default.

    Returns
    -------
    PngDrawing
    """
    if workers is None:
        workers = draw_workers(len(figs))
    return PngDrawing(figs, draw, workers)
