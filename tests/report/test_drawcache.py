"""Ticks, tick-label boxes and text metrics computed once per state while a report draws
(``volcal.report.drawcache``, issue 31): the same bytes as matplotlib's own drawing, a
change between two drawings seen, matplotlib left as it was."""

import io

import matplotlib.text as mtext
import numpy as np
from matplotlib.axis import Axis
from matplotlib.backends.backend_pdf import PdfPages

from volcal.plot._figure import new_figure
from volcal.report.drawcache import cached_drawing


def _figure(xlim=None):
    """Shared axes, aligned labels, titles, a colour bar, a log axis, a legend."""
    fig = new_figure(6.0, 4.0)
    axs = fig.subplots(2, 2, sharex="col")
    x = np.linspace(0.0, 950.0, 40)
    for k, ax in enumerate(axs.flat):
        ax.plot(x, np.sin(x / 100.0 + k) * 10 ** k, label=f"E{k} [µm]")
        ax.set_title(f"axis {k}: deviation")
        ax.set_ylabel("deviation [µm]")
    axs[1, 1].set_yscale("log")
    im = axs[0, 1].imshow(np.arange(12.0).reshape(3, 4), aspect="auto")
    fig.colorbar(im, ax=axs[0, 1], label="|e| [µm]")
    axs[0, 0].legend(fontsize=6.5)
    fig.align_ylabels(axs[:, 0])
    fig.suptitle("error functions")
    if xlim is not None:
        axs[1, 0].set_xlim(*xlim)
    return fig


def _png(fig):
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=60, metadata={"Software": None})
    return buf.getvalue()


def _pdf(figs):
    buf = io.BytesIO()
    with PdfPages(buf, metadata={"CreationDate": None, "Producer": None}) as pdf:
        for fig in figs:
            pdf.savefig(fig)
    return buf.getvalue()


def test_same_bytes_as_without_the_cache():
    plain_png, plain_pdf = _png(_figure()), _pdf([_figure(), _figure((100.0, 600.0))])
    with cached_drawing():
        png = _png(_figure())
        pdf = _pdf([_figure(), _figure((100.0, 600.0))])
    assert png == plain_png
    assert pdf == plain_pdf


def _twice(fig):
    first = _png(fig)
    fig.axes[2].set_xlim(200.0, 400.0)  # the shared column follows
    return first, _png(fig)


def test_a_change_between_two_drawings_is_drawn():
    expected = _twice(_figure())
    with cached_drawing():
        got = _twice(_figure())
    assert got == expected and expected[0] != expected[1]


def test_matplotlib_left_as_it_was():
    update, boxes = Axis._update_ticks, Axis._get_ticklabel_bboxes
    metrics = mtext._get_text_metrics_function
    fig = _figure()
    with cached_drawing():
        with cached_drawing():  # re-entrant
            _png(fig)
        assert Axis._update_ticks is not update
        _png(fig)
    assert (Axis._update_ticks, Axis._get_ticklabel_bboxes) == (update, boxes)
    assert mtext._get_text_metrics_function is metrics
    assert not any(k.startswith("_volcal") for ax in fig.axes
                   for axis in (ax.xaxis, ax.yaxis) for k in vars(axis))
