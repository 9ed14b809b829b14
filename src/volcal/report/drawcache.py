"""Matplotlib's repeated questions answered once while a report's figures and pages are drawn.

While matplotlib draws a figure with constrained layout it asks every axis for its ticks
(``Axis._update_ticks``: locator, formatter, tick objects) and for the boxes of their
labels (``Axis._get_ticklabel_bboxes``) 15-20 times: twice per layout iteration for the
axes' tight boxes, again for each axis label's position, for the titles' heights, and
once more to draw them. Between two of those questions nothing that decides the answer
changes unless the layout moved the axes. And it measures every text (``FT2Font.set_text``:
the text shaped and each glyph loaded, 0.2-1.5 ms a text) in a cache of the renderer
that draws it, so each new PDF page (a new renderer) measures again the texts of the
pages before it.

:func:`cached_drawing` keeps, while it is active:

- for each axis, the last ticks and label boxes with the state they were computed from
  (the view interval, the axes' box in display units, the figure's resolution, the
  scale, the locators and formatters; for the boxes also the renderer and the ticks); an
  equal state gives the same answer, any other state computes it anew;
- one text-metrics cache for all renderers of one kind and resolution (matplotlib's
  ``_get_text_metrics_with_cache``, which keeps one per renderer): a text's width, height
  and descent depend on the text, its font properties, the renderer's kind (Agg, PDF)
  and resolution, not on which page measures it.

The figures drawn are the same bytes with and without it
(``tests/report/test_report_render.py``). It patches private matplotlib functions for
the duration of the block and changes nothing where they are missing (another
matplotlib version).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import matplotlib.text as _mtext
from matplotlib.axis import Axis

__all__ = ["cached_drawing", "text_metrics"]

_TICKS = "_volcal_ticks"
_BOXES = "_volcal_tick_boxes"
_depth = 0
_seen: list[Axis] = []
_metrics: dict[tuple[Any, ...], tuple[float, float, float]] = {}

_update_ticks = getattr(Axis, "_update_ticks", None)
_ticklabel_bboxes = getattr(Axis, "_get_ticklabel_bboxes", None)
_metrics_function = getattr(_mtext, "_get_text_metrics_function", None)


def _state(axis: Axis) -> tuple[Any, ...]:
    """What an axis's ticks and the boxes of their labels are computed from."""
    ax = axis.axes
    return (tuple(axis.get_view_interval()), ax.bbox.bounds, ax.figure.dpi, axis.get_scale(),
            id(axis.major.locator), id(axis.major.formatter), id(axis.minor.locator),
            id(axis.minor.formatter))


def _cached_update_ticks(self: Axis) -> list[Any]:
    state = _state(self)
    hit = self.__dict__.get(_TICKS)
    if hit is not None and hit[0] == state:
        return list(hit[1])
    assert _update_ticks is not None
    ticks = _update_ticks(self)
    if _TICKS not in self.__dict__:
        _seen.append(self)
    self.__dict__[_TICKS] = (state, ticks)
    self.__dict__.pop(_BOXES, None)
    return list(ticks)


def _cached_ticklabel_bboxes(self: Axis, ticks: list[Any], renderer: Any) -> Any:
    key = (id(renderer), [id(t) for t in ticks], _state(self))
    boxes = self.__dict__.get(_BOXES)
    if boxes is not None and boxes[0] == key:
        return list(boxes[1][0]), list(boxes[1][1])
    assert _ticklabel_bboxes is not None
    out = _ticklabel_bboxes(self, ticks, renderer)
    if _TICKS in self.__dict__:  # forgotten when the ticks change, and at the block's end
        self.__dict__[_BOXES] = (key, out)
    return list(out[0]), list(out[1])


def _kind(renderer: Any) -> tuple[Any, Any]:
    """What a renderer's text metrics depend on besides the text: its kind and resolution.

    A PDF renderer measures in points whatever the figure's resolution; Agg in pixels
    at its own.
    """
    inner = getattr(renderer, "_renderer", renderer)  # a PDF page's mixed-mode renderer
    return type(inner), getattr(inner, "dpi", None)


def text_metrics(renderer: Any, text: str, prop: Any,
                 ismath: Any = False) -> tuple[float, float, float]:
    """Width, height and descent of a text as ``renderer`` measures it [its units].

    Inside :func:`cached_drawing` from the block's cache, shared with every renderer of
    the same kind and resolution (so a text measured here to lay a page out is not
    measured again when the page draws it); outside, measured.

    Parameters
    ----------
    renderer : RendererBase
        The renderer (or one of the same kind and resolution as the one that will draw).
    text : str
        One line of text.
    prop : FontProperties
        Its font (not changed afterwards: it is part of the cache's key).
    ismath : bool or str
        As ``RendererBase.get_text_width_height_descent``.

    Returns
    -------
    tuple of float
    """
    if not _depth:
        return renderer.get_text_width_height_descent(text, prop, ismath)
    key = (_kind(renderer), text, prop, ismath)
    hit = _metrics.get(key)
    if hit is None:
        hit = _metrics[key] = renderer.get_text_width_height_descent(text, prop, ismath)
    return hit


def _shared_metrics_function(renderer: Any) -> Callable[..., tuple[float, float, float]]:
    """Text metrics for matplotlib, cached across renderers of one kind and resolution."""

    def metrics(text: str, fontprop: Any, ismath: Any, dpi: float) -> tuple[float, float, float]:
        return text_metrics(renderer, text, fontprop, ismath)

    return metrics


def _patch(update: Any, boxes: Any, metrics: Any) -> None:
    """Set matplotlib's three functions (private: set by name)."""
    for owner, name, value in ((Axis, "_update_ticks", update),
                               (Axis, "_get_ticklabel_bboxes", boxes),
                               (_mtext, "_get_text_metrics_function", metrics)):
        setattr(owner, name, value)


@contextmanager
def cached_drawing() -> Iterator[None]:
    """Within this block, ticks, their labels' boxes and text metrics are computed once.

    Re-entrant; the caches are dropped when the outermost block ends. Not for threads
    drawing at the same time (the report draws in one thread, or in forked processes).
    """
    global _depth
    if _update_ticks is None or _ticklabel_bboxes is None or _metrics_function is None:
        yield
        return
    if _depth == 0:
        _patch(_cached_update_ticks, _cached_ticklabel_bboxes, _shared_metrics_function)
    _depth += 1
    try:
        yield
    finally:
        _depth -= 1
        if _depth == 0:
            _patch(_update_ticks, _ticklabel_bboxes, _metrics_function)
            for axis in _seen:
                axis.__dict__.pop(_TICKS, None)
                axis.__dict__.pop(_BOXES, None)
            _seen.clear()
            _metrics.clear()
