"""Figures as embedded images: PNG bytes and ``data:`` URIs for a self-contained HTML file.

In a written report each figure is drawn once, as vector graphics on its PDF page, and its
PNG (the HTML and the figures folder) is that page's figure area rasterized
(:mod:`volcal.report.pdf`, :mod:`volcal.report.raster`), kept on its item
(:attr:`volcal.report.document.FigureItem.png`). Outside a report
(:func:`volcal.report.html.render_html` alone, a user's own figure) :func:`png_bytes`
draws a figure at its own size with matplotlib's Agg. Figures independent of each other are
drawn in worker processes where the machine has cores to spare (:func:`draw_all`,
:func:`draw_workers`).
"""

from __future__ import annotations

import base64
import io
import math
import multiprocessing
import os
import pickle
import queue
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any, Generic, TypeVar

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from volcal.report.drawcache import cached_drawing

__all__ = ["PNG_COMPRESSION", "PNG_DPI", "WORKERS_ENV", "Drawing", "draw_all", "draw_workers",
           "kept_layout", "png_bytes", "png_data_uri", "spare_cores",
           "watch_cores"]

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
    once (on its PDF page, or as a PNG) is laid out a hair differently the next time. A
    report's figure page puts the figure back as built, so the figure object is left as it
    was and :func:`png_bytes` gives the same bytes before or after the page.

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


def _cpu_times() -> tuple[float, float] | None:
    """Idle and total time of all the machine's cores so far [clock ticks], or None.

    From the first line of Linux's ``/proc/stat`` (``proc(5)``): idle is ``idle`` plus
    ``iowait``, total the sum of the first eight fields (user, nice, system, idle,
    iowait, irq, softirq, steal).
    """
    try:
        with open("/proc/stat", encoding="ascii") as f:
            fields = f.readline().split()
    except OSError:
        return None
    if len(fields) < 5 or fields[0] != "cpu":
        return None
    try:
        v = [float(x) for x in fields[1:9]]
    except ValueError:
        return None
    return v[3] + v[4], sum(v)


_SINCE = (_cpu_times(), time.monotonic())
"""The cores' times at the start of the window in which :func:`spare_cores` sees how busy
the machine is while the report does its own work: when this module was imported, or
when :func:`watch_cores` was last called."""


def watch_cores() -> None:
    """Start the window of :func:`spare_cores` now (a report's first step).

    A report written in a long-running process (a notebook, a service) would otherwise
    count every idle minute since the module was imported.
    """
    global _SINCE
    _SINCE = (_cpu_times(), time.monotonic())

MIN_WINDOW_S = 0.1
"""Shortest window [s] over which :func:`spare_cores` trusts the cores' idle time (ten of
``/proc/stat``'s 10 ms ticks per core); a shorter one falls back on the load average."""


def spare_cores() -> float | None:
    """Cores that stood idle since the window started, on average, or None.

    While a report reads, evaluates and builds, this process keeps one core busy; the
    idle time of the others over that window (``/proc/stat``) is what a worker drawing
    beside it would get. Unlike the one-minute load average it sees the machine as it is
    now: a report run just before, which lifts the load average to about 1 for a minute,
    is not counted as still running.

    Returns
    -------
    float or None
        Idle cores (0 .. core count); None where ``/proc/stat`` is missing or the window
        is shorter than :data:`MIN_WINDOW_S`.
    """
    start, t0 = _SINCE
    now = _cpu_times()
    if start is None or now is None or time.monotonic() - t0 < MIN_WINDOW_S:
        return None
    total = now[1] - start[1]
    if total <= 0:
        return None
    return (now[0] - start[0]) / total * (os.cpu_count() or 1)


def draw_workers(jobs: int, busy: int = 1) -> int:
    """How many worker processes may draw figures now.

    Parameters
    ----------
    jobs : int
        Figures to draw.
    busy : int
        Processes of this program that stay busy meanwhile (this one, printing the PDF's
        text pages).

    Returns
    -------
    int
        :data:`WORKERS_ENV` when set; else the cores that stood idle while this report
        did its own work (:func:`spare_cores`, rounded: a worker where half a core or
        more was idle), or, where that is not known, the core count less the one-minute
        load average (:func:`os.getloadavg`) less ``busy``, rounded; at most ``jobs`` and
        the core count less ``busy``; 0 (draw in this process) where the ``fork`` start
        method is not available.

    Raises
    ------
    ValueError
        If :data:`WORKERS_ENV` is not a whole number >= 0.
    """
    given = os.environ.get(WORKERS_ENV, "").strip()
    cores = os.cpu_count() or 1
    if given:
        if not given.isdigit():
            raise ValueError(f"{WORKERS_ENV}={given!r}: expected a whole number >= 0")
        n = int(given)
    else:
        idle = spare_cores()
        if idle is None:
            try:
                load = os.getloadavg()[0]
            except (AttributeError, OSError):
                return 0
            idle = cores - load - busy
        n = min(math.floor(idle + 0.5), cores - busy)
    if "fork" not in multiprocessing.get_all_start_methods():
        return 0
    return max(0, min(jobs, n))


T = TypeVar("T")
R = TypeVar("R")

_POLL_S = 0.05  # how often a waiting process looks whether its workers still live [s]


class Drawing(Generic[T, R]):
    """Items being drawn, in worker processes and in this one, each by one process.

    Parameters
    ----------
    items : sequence
        What to draw (each one independent of the others).
    draw : callable
        Draws one item; what it returns is sent back from a worker (picklable).
    workers : int
        Worker processes, forked now (0: the items are drawn in this process by
        :meth:`result`).
    weight : callable, optional
        The larger, the earlier an item is taken (the largest first, so that the
        processes finish together).

    Notes
    -----
    The items are taken in turn from one shared counter, by the workers as soon as they
    start and by this process once it calls :meth:`result` (work stealing): whichever
    process is free takes the next item, so the processes end within about one item of
    each other whatever the load. A worker that dies (killed, out of memory) or fails
    does not hang or lose the report: the items it took and did not return are drawn in
    this process (where a real error then shows itself).
    """

    def __init__(self, items: Sequence[T], draw: Callable[[T], R], workers: int,
                 weight: Callable[[T], float] | None = None) -> None:
        self.items, self.draw = list(items), draw
        order = list(range(len(self.items)))
        if weight is not None:
            order.sort(key=lambda i: -weight(self.items[i]))
        self._order = order
        self._procs: list[Any] = []
        self._shared = bool(workers and self.items)  # the counter is shared, in the workers too
        if self._shared:
            ctx = multiprocessing.get_context("fork")
            self._next = ctx.Value("i", 0)
            self._results = ctx.Queue()
            with warnings.catch_warnings():  # a fork beside the console's status thread:
                warnings.simplefilter("ignore", DeprecationWarning)  # the child only draws
                for _ in range(workers):
                    proc = ctx.Process(target=self._work, daemon=True)
                    proc.start()
                    self._procs.append(proc)

    def _take(self) -> int | None:
        """The next item nobody has taken, or None."""
        if not self._shared:
            return self._order.pop(0) if self._order else None
        with self._next.get_lock():
            k = self._next.value
            if k >= len(self._order):
                return None
            self._next.value = k + 1
        return self._order[k]

    def _work(self) -> None:
        """A worker's loop: take, draw, send, until nothing is left."""
        while (i := self._take()) is not None:
            try:
                self._results.put((i, True, self.draw(self.items[i])))
            except BaseException as e:  # sent back: this process draws it again
                self._results.put((i, False, repr(e)))
        self._results.close()
        self._results.join_thread()

    def result(self) -> list[R]:
        """What each item drew, in the order given.

        Returns
        -------
        list
        """
        done: dict[int, R] = {}
        while (i := self._take()) is not None:
            done[i] = self.draw(self.items[i])
        failed: list[int] = []
        while self._procs and len(done) + len(failed) < len(self.items):
            try:
                i, ok, value = self._results.get(timeout=_POLL_S)
            except queue.Empty:
                if not any(p.is_alive() for p in self._procs) and self._results.empty():
                    break  # every worker gone: what they took and did not send is redone
                continue
            except (EOFError, OSError, pickle.UnpicklingError):
                break  # a message cut off by a worker killed as it sent: redone here
            if ok:
                done[i] = value
            else:
                failed.append(i)
        self.close()
        for i in range(len(self.items)):
            if i not in done:
                done[i] = self.draw(self.items[i])
        return [done[i] for i in range(len(self.items))]

    def close(self) -> None:
        """Stop the workers (after :meth:`result`, or when the report failed meanwhile)."""
        for p in self._procs:
            if p.is_alive():
                p.terminate()
            p.join()
        if self._procs:
            self._results.close()
        self._procs = []

    @property
    def parallel(self) -> bool:
        """Whether worker processes draw the items."""
        return bool(self._procs)


def draw_all(items: Sequence[T], draw: Callable[[T], R], workers: int | None = None,
             weight: Callable[[T], float] | None = None) -> Drawing[T, R]:
    """Start drawing items independent of each other.

    With workers, the items are drawn in processes forked now (each one inherits the
    items as they are, so the drawing does not depend on what this process does with
    them meanwhile) while this process goes on; without, they are drawn here by
    :meth:`Drawing.result`.

    Parameters
    ----------
    items : sequence
        What to draw (matplotlib figures on their own canvases: no global state).
    draw : callable
        Draws one item.
    workers : int, optional
        Worker processes; :func:`draw_workers` by default.
    weight : callable, optional
        Queue order, the largest first.

    Returns
    -------
    Drawing
    """
    if workers is None:
        workers = draw_workers(len(items))
    return Drawing(items, draw, workers, weight)
