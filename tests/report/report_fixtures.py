"""Fixtures of the report tests (a uniquely named module: tests/conftest.py is imported by
name elsewhere, so this folder has no conftest.py of its own)."""

import shutil
import subprocess
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from timing import scaled_timeout
from volcal.measure.simulate import SimulationOptions, simulate_session, truth_files
from volcal.measure.virtual import random_machine
from volcal.plan.planner import plan_session
from volcal.session.format import read_session, write_session

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                  "--no-first-run", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync"]


_SHARED: dict = {}
"""Values of the session fixtures, shared by every test module that binds them (each module
binds its own fixture definitions, and pytest caches a session fixture per definition)."""


def _shared(key, make):
    if key not in _SHARED:
        _SHARED[key] = make()
    return _SHARED[key]


@pytest.fixture(scope="session")
def small_session(tmp_path_factory) -> Path:
    """A simulated session: the full test set on a small grid (fast to identify)."""
    return _shared("small_session", lambda: _small_session(tmp_path_factory))


def _small_session(tmp_path_factory) -> Path:
    travel = np.array([[0, 400], [0, 300], [0, 250]], float)
    s = plan_session(travel, "XYFZ", 5, ("step-diagonal", "diagonal", "linear"), 3,
                     name="TEST-VMC")
    vm = random_machine(travel, "XYFZ", seed=11, n_nodes=21)
    opts = SimulationOptions(noise_um=0.3, seed=11)
    setups = simulate_session(s, vm, opts)
    folder = tmp_path_factory.mktemp("sess") / "session"
    write_session(s, folder, truth_files(vm, setups, opts))
    return folder


@pytest.fixture(scope="session")
def identified(small_session):
    from volcal.identify import identify

    def make():
        s = read_session(small_session)
        return s, identify(s)

    return _shared("identified", make)


def figure_data(fig) -> list:
    """What a figure shows, axes by axes: the data of its lines, collections (scatter,
    bands, arrows, bars), images and patches, and its titles, labels and legends, in
    drawing order (not its pixels; tick marks and tick labels are made by the drawing)."""
    from matplotlib.collections import Collection
    from matplotlib.image import AxesImage
    from matplotlib.lines import Line2D
    from matplotlib.patches import Rectangle
    from matplotlib.quiver import Quiver
    from matplotlib.text import Text

    out: list = []

    def text(t):
        if t is not None and t.get_text():
            out.append(("text", t.get_text()))

    for ax in fig.axes:
        for a in ax.get_children():
            if isinstance(a, Line2D):
                out.append(("line", a.get_gid(), np.asarray(a.get_xydata(), float).tolist(),
                            a.get_marker(), a.get_linestyle(), a.get_color()))
            elif isinstance(a, Quiver):  # the arrows' shapes are made by the drawing
                out.append(("quiver", a.get_gid(), np.asarray(a.get_offsets()).tolist(),
                            np.asarray(a.U).tolist(), np.asarray(a.V).tolist(),
                            np.asarray(a.get_array()).tolist(), a.scale))
            elif isinstance(a, Collection):
                arr = a.get_array()
                out.append(("collection", type(a).__name__, a.get_gid(),
                            np.asarray(a.get_offsets(), float).tolist(),
                            [np.asarray(p.vertices).tolist() for p in a.get_paths()],
                            None if arr is None else np.asarray(arr).tolist()))
            elif isinstance(a, AxesImage):
                out.append(("image", np.asarray(a.get_array()).tolist()))
            elif isinstance(a, Rectangle) and a is not ax.patch:
                out.append(("rectangle", a.get_gid(), a.get_xy(), a.get_width(),
                            a.get_height(), a.get_hatch()))
            elif isinstance(a, Text):
                text(a)
        for t in (ax.xaxis.label, ax.yaxis.label):
            text(t)
        legend = ax.get_legend()
        for t in legend.get_texts() if legend is not None else []:
            text(t)
    for t in fig.texts:
        text(t)
    text(getattr(fig, "_suptitle", None))
    return out


@pytest.fixture(scope="session")
def written_report(identified, tmp_path_factory):
    """The small session's report built and written once (drawn for real, in this process:
    see :func:`written_report_drawing`)."""
    from volcal.report.pipeline import collect_inputs
    from volcal.report.sections import build_report
    from volcal.report.writer import write_report

    def make():
        from matplotlib.lines import Line2D

        s, r = identified
        rep = build_report(collect_inputs(s, r))
        with pytest.MonkeyPatch.context() as mp:
            drawing = _watch_drawing(mp, rep)
            files = write_report(rep, tmp_path_factory.mktemp("rep") / "report")
        drawing.after = [figure_data(f.figure) for f in rep.figures]
        drawing.left = [(f.figure.get_layout_engine() is not None,
                         type(f.figure.canvas).__name__,
                         any(a.get_rasterized() for a in f.figure.findobj(Line2D)))
                        for f in rep.figures]
        _SHARED["written_report_drawing"] = drawing
        return rep, files

    return _shared("written_report", make)


def _watch_drawing(mp: pytest.MonkeyPatch, rep) -> SimpleNamespace:
    """Count each figure's drawings while ``mp`` holds, by renderer ("pdf": its PDF page,
    "png": an Agg drawing), all in this process (no drawing workers, where the drawings
    could not be counted); record what the figures show before."""
    from matplotlib.figure import Figure

    from volcal.report.figures import WORKERS_ENV

    watched = SimpleNamespace(before=[figure_data(f.figure) for f in rep.figures], drawn={})
    draw = Figure.draw

    def counting(fig, renderer):
        key = (id(fig), "pdf" if type(renderer).__name__ == "MixedModeRenderer" else "png")
        watched.drawn[key] = watched.drawn.get(key, 0) + 1
        return draw(fig, renderer)

    mp.setattr(Figure, "draw", counting)
    mp.setenv(WORKERS_ENV, "0")
    return watched


@pytest.fixture(scope="session")
def written_report_drawing(written_report) -> SimpleNamespace:
    """How :func:`written_report` was drawn: ``drawn`` {(id(figure), "pdf" | "png"):
    count}; ``before`` and ``after`` the figures' data (:func:`figure_data`) before and
    after the writing; ``left`` per figure (has a layout engine, its canvas's type name,
    any line rasterized) after the writing. Recorded as it was written (a later test may
    use the figures)."""
    return _SHARED["written_report_drawing"]


@pytest.fixture
def chromium(tmp_path):
    """Run headless chromium with the test flags and a throw-away profile."""
    if not Path(CHROMIUM).exists():
        pytest.skip("chromium is not installed (make browser-deps installs it)")
    profile = tmp_path / "chromium-profile"
    profile.mkdir(exist_ok=True)

    def run(args: list[str], timeout: float = 120.0):
        return subprocess.run([CHROMIUM, *CHROMIUM_FLAGS, f"--user-data-dir={profile}", *args],
                              capture_output=True, text=True, timeout=scaled_timeout(timeout))

    return run
