"""The history's trend figure (volcal.plot.trend): the caller's matplotlib state untouched."""

from __future__ import annotations

import datetime
import subprocess
import sys

import numpy as np
import pytest

from volcal.errors import VolcalInputError
from volcal.plot.trend import trend_plot, write_trend_plot

ROWS = [
    {"id": "c1", "date": "2025-03-01T10:00:00", "value": 4.25, "U": 0.5, "unit": "um"},
    {"id": "c2", "date": "2025-09-15", "value": None, "U": None, "unit": ""},
    {"id": "c3", "date": "2026-01-10", "value": 6.5, "U": None, "unit": "um"},
]


def test_points_and_bars():
    fig = trend_plot(ROWS, "X.A", "VMC-1")
    ax = fig.axes[0]
    line = ax.lines[0]
    # the calibration without a value is left out; dates on x, values on y
    assert list(line.get_ydata()) == [4.25, 6.5]
    assert list(line.get_xdata()) == [datetime.date(2025, 3, 1), datetime.date(2026, 1, 10)]
    # the error bar of c1 spans value +- U; c3 (no U) has a bar of zero length
    segs = ax.collections[0].get_segments()
    assert np.allclose([s[:, 1] for s in segs], [[3.75, 4.75], [6.5, 6.5]])
    assert ax.get_ylabel() == "X.A [µm]" and "VMC-1" in ax.get_title()


def test_writes_png_atomically(tmp_path):
    out = write_trend_plot(ROWS, "X.A", "VMC-1", tmp_path / "t.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in tmp_path.iterdir()] == ["t.png"]


def test_unknown_suffix_is_refused(tmp_path):
    with pytest.raises(VolcalInputError, match=r"t\.xyz: the figure's format.*\.png"):
        write_trend_plot(ROWS, "X.A", "VMC-1", tmp_path / "t.xyz")
    assert not list(tmp_path.iterdir())


def test_caller_backend_and_pyplot_untouched(tmp_path):
    """A caller on another backend keeps it; pyplot is never imported."""
    code = ("import sys, matplotlib\nmatplotlib.use('svg')\n"
            "from volcal.plot.trend import write_trend_plot\n"
            f"write_trend_plot({ROWS!r}, 'X.A', 'VMC-1', sys.argv[1])\n"
            "assert matplotlib.get_backend() == 'svg', matplotlib.get_backend()\n"
            "assert 'matplotlib.pyplot' not in sys.modules\n")
    r = subprocess.run([sys.executable, "-c", code, str(tmp_path / "t.pdf")],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "t.pdf").read_bytes()[:5] == b"%PDF-"
