"""The end-to-end demonstration: plan, simulate, identify, evaluate, compensate, report.

The demo drives the facade (:class:`volcal.flow.Calibration`), so it lives beside it, on
top of the rooms it calls (docs/architecture.md).

A virtual machining centre (travel 800 x 600 x 500 mm, chain XYFZ: the table carries X
and Y, the column carries Z) is measured with the seeds' full test set (4 step diagonals
with a flat mirror, 4 body diagonals, 3 linear lines per axis with 5 bidirectional runs;
10 increments each), identified, evaluated to ISO 230-2 / 230-6 and compensated with a
3-D error grid; the as-left measurement is rehearsed (the same plan simulated on the same
machine with the grid active, ``volcal simulate --compensation``) and identified, and the
report pairs as found and as left. Last, one body diagonal of a new plan is captured live
(``volcal capture``) on the
simulated control, which runs volcal's part program with acceleration and dwells, and the
simulated laser reading the same virtual machine; its readings are compared with the
machine's truth. Every output is written atomically.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from volcal.flow import Calibration
from volcal.measure.virtual import ErrorRanges, random_machine
from volcal.report.writer import ReportFiles

__all__ = ["DEMO_STEPS", "DEMO_TRAVEL", "DemoOutput", "run_demo"]

DEMO_TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])
"""Work zone of the demo machine [mm]."""

DEMO_STEPS: tuple[str, ...] = ("plan", "simulate", "identify", "compensate", "evaluate",
                               "as-left", "report", "capture")


@dataclass
class DemoOutput:
    """What the demo wrote.

    Attributes
    ----------
    folder : Path
        Output folder.
    session : Path
        Simulated session folder (truth in ``truth/``).
    model : Path
        Identified model file.
    compensation : Path or None
        Compensation tables folder.
    report : ReportFiles
        The report.
    capture : Path or None
        The session captured live on the simulated control and laser.
    summary : list of str
        Plain-text lines describing the run.
    as_left : Path or None
        The as-left session: the plan simulated with the compensation grid active.
    """

    folder: Path
    session: Path
    model: Path
    compensation: Path | None
    report: ReportFiles
    capture: Path | None = None
    summary: list[str] = field(default_factory=list)
    as_left: Path | None = None


def _noop(*_args: object) -> None:
    return None


def run_demo(folder: str | Path, seed: int = 7,
             on_step: Callable[[str], None] = _noop,
             on_done: Callable[[], None] = _noop) -> DemoOutput:
    """Run the whole flow on a virtual machine.

    Parameters
    ----------
    folder : str or Path
        Output folder; ``session/``, ``model.json``, ``compensation/``, ``as-left/``,
        ``report/`` and ``capture/`` are written inside it.
    seed : int
        Seed of the virtual machine and of the simulated noise.
    on_step : callable, optional
        Called with a description when a step starts (progress display).
    on_done : callable, optional
        Called when a step ends.

    Returns
    -------
    DemoOutput
    """
    folder = Path(folder)
    lines: list[str] = []
    def planned() -> Calibration:  # the seeds' full test set, as found and as left
        return Calibration.plan(DEMO_TRAVEL, "XYFZ", 10, ("step-diagonal", "diagonal",
                                                          "linear"), 5, name="VMC-800")

    on_step("planning the seeds' full test set")
    cal = planned()
    s = cal.session
    lines.append(f"plan: {len(s.measurements)} measurements, "
                 f"{sum(m.n for m in s.measurements)} readings")
    on_done()

    on_step("simulating a virtual machining centre")
    vm = random_machine(DEMO_TRAVEL, "XYFZ", seed, ranges=ErrorRanges(reversal_um=(1.0, 3.0)),
                        name="virtual VMC-800")
    noise, mirror = 0.5, 20.0
    cal.simulate(vm, seed=seed, noise_um=noise, mirror_misalignment_urad=mirror)
    session_dir = folder / "session"
    cal.save(session_dir)
    lines.append(f"simulate: noise {noise} µm, mirror misalignment {mirror} µrad -> "
                 f"{session_dir}")
    on_done()

    on_step("identifying the 21 errors")
    result = cal.identify()
    model = folder / "model.json"
    result.to_json(model)
    lines.append(f"identify: residual {result.fit.sigma_residual_um:.2f} µm over "
                 f"{result.fit.n_readings} readings -> {model}")
    on_done()

    on_step("writing compensation tables")
    comp_dir = folder / "compensation"
    grid_files = cal.compensate(comp_dir, format="grid", spacing=50.0)  # grid's sign: error
    lines.append(f"compensate: 3-D error grid ({', '.join(grid_files)}) -> {comp_dir}")
    on_done()

    on_step("evaluating to ISO 230-2 / 230-6")
    ev = cal.evaluate()
    if ev.volumetric is not None:
        lines.append(f"evaluate: E_VXYZ = {ev.volumetric.E_VXYZ:.1f} µm")
    from volcal.report.pipeline import compensation_summary

    cs = compensation_summary(result, s.travel, vm, comp_dir)
    if cs.truth_residual_max_um:
        lines.append(f"          after the 3-D grid compensation at most "
                     f"{cs.truth_residual_max_um:.1f} µm remain (truth)")
    on_done()

    on_step("rehearsing the as-left with the grid loaded")
    left = planned()
    left.simulate(vm, seed=seed + 1, noise_um=noise, mirror_misalignment_urad=mirror,
                  compensation=comp_dir)
    left_dir = folder / "as-left"
    left.save(left_dir)
    left.identify()
    ev_left = left.evaluate()
    if ev.volumetric is not None and ev_left.volumetric is not None:
        lines.append(f"as-left: the same plan with the grid active -> {left_dir}; E_VXYZ "
                     f"{ev_left.volumetric.E_VXYZ:.1f} µm (as found "
                     f"{ev.volumetric.E_VXYZ:.1f} µm)")
    on_done()

    on_step("writing the HTML and PDF report")
    files = cal.report(folder / "report", compensation=comp_dir, as_left=left,
                       tables=comp_dir)
    lines.append(f"report: {files.pdf_pages} PDF pages, {len(files.figures)} figures")
    cert = files.folder / "certificate.pdf"
    if cert.is_file():
        elv = [(e or {}).get("ELv") for e in (ev.elv, ev_left.elv)]
        said = (f", ELv {elv[0]:.1f} -> {elv[1]:.1f} µm" if None not in elv else "")
        lines.append(f"certificate: as found and as left{said} -> {cert}")
    on_done()

    on_step("capturing a diagonal live on the simulated control and laser")
    captured = folder / "capture"
    lines += _capture(captured, session_dir, vm)
    on_done()
    return DemoOutput(folder, session_dir, model, comp_dir, files, captured, lines, left_dir)


def _capture(folder: Path, session_dir: Path, vm: object) -> list[str]:
    """Capture body diagonal ppp of a new plan on the simulated control and laser."""
    from volcal.session.format import read_session
    from volcal.session.kinds import kind_of
    from volcal.steps.capture import capture
    from volcal.steps.plan import plan

    plan(DEMO_TRAVEL, tests="diagonal", steps=4, name="VMC-800", output=folder,
         replace=(folder / "session.toml").is_file())  # a demo run again: a fresh capture
    machine = session_dir / "truth" / "machine.csv"  # the simulated machine, as a table
    r = capture(folder, control="sim", laser=f"sim:machine={machine},noise=0.05",
                measurement=["diag-ppp"], dwell_s=2.0, stable_s=0.6, max_gap_s=0.3,
                poll_s=0.05)
    m = read_session(folder).get("diag-ppp")
    if m.deviation is None:
        return ["capture: diag-ppp recorded no reading"]
    truth = kind_of(m.kind).exact(vm, m)
    o = r.outcomes[0]
    return [f"capture: diag-ppp live ({o.accepted} of {o.planned} dwells accepted, "
            f"{len(o.missed)} missed); largest difference to the machine's truth "
            f"{float(np.max(np.abs(m.deviation - truth))):.2f} µm -> {folder}"]
