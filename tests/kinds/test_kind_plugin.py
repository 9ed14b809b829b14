"""A measurement kind defined entirely in this test module goes through the whole flow.

The kind ``tilt`` is a tilt sensor (an electronic level, or an inclinometer on the tool)
reading one rotation of the tool (``rotation = "a" | "b" | "c"``) along a linear move of
one axis, in ``tilt_urad`` [urad]. Nothing in volcal's own files knows it: the test
registers it (:func:`volcal.kinds.register_kind`), then the command line plans it
(``volcal plan --tests tilt``), simulates it, reads it back, identifies the machine with
it, and the report carries the kind's own section (the HTML report's document model, no
PDF). It also passes the contract every kind passes (``test_kind_contract.py``).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
import pytest
import scipy.sparse as sp
from test_kind_contract import (
    check_first_order,
    check_refusals,
    check_round_trip,
    planned_session,
)

from volcal.errors import VolcalInputError
from volcal.kinds import Kind, ReadContext, RowBlock, kind_names, register_kind, unregister_kind
from volcal.model.kinematics import URAD, exact_pose, pose_jacobian
from volcal_cli_helpers import run_volcal

ROTATIONS = "abc"


def _rotvec(R: np.ndarray) -> np.ndarray:
    """Rotation vectors of small rotation matrices (first order is enough below 1e-3 rad)."""
    return 0.5 * np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0],
                           R[:, 1, 0] - R[:, 0, 1]], axis=1)


class TiltKind(Kind):
    """Tilt sensor on the tool: one rotation [urad] along a linear move of one axis."""

    name: ClassVar[str] = "tilt"
    targets: ClassVar[tuple[str, ...]] = ("tilt_sensor",)
    own_targets: ClassVar[tuple[str, ...]] = ("tilt_sensor",)
    value_column: ClassVar[str] = "tilt_urad"
    value_unit: ClassVar[str] = "urad"
    beam_in_session: ClassVar[bool] = False
    plan_tests: ClassVar[tuple[str, ...]] = ("tilt",)
    description: ClassVar[str] = "tilt sensor: one rotation of the tool along one axis"

    def read(self, entry: dict[str, Any], ctx: ReadContext) -> Any:
        from volcal.session.format import Measurement, missed_dropped, read_rows

        meta = {k: v for k, v in entry.items()
                if k not in ("id", "kind", "target", "file", "tool_offset_mm")}
        for key, valid in (("axis", "xyz"), ("rotation", ROTATIONS)):
            v = entry.get(key)
            if not isinstance(v, str) or v not in valid:
                raise VolcalInputError(f"{key} must be one of {', '.join(valid)}, got {v!r}",
                                       ctx.toml_path, None, f"{ctx.where}.{key}")
        r = read_rows(ctx.csv_path, self.value_column)
        k = "xyz".index(meta["axis"])
        r = missed_dropped(r, meta, ctx)
        return Measurement(ctx.id, self.name, ctx.target, r.positions, r.deviation,
                           np.eye(3)[k], ctx.tool_offset, ctx.file, r.columns, meta, r.rows)

    def axis(self, m: Any) -> int | None:
        return "xyz".index(m.meta["axis"])

    def exact(self, machine: Any, m: Any, setup: Any = None) -> np.ndarray:
        _, R = exact_pose(machine, m.positions, m.tool_offset)
        rel = np.einsum("mij,kj->mik", R, R[0])  # rotation since the first reading
        return _rotvec(rel)[:, ROTATIONS.index(m.meta["rotation"])] / URAD

    def rows(self, chain_order: Any, nodes: Any, m: Any, *, drift: bool = False,
             tilts: bool = True) -> RowBlock:
        _, Jo = pose_jacobian(chain_order, nodes, m.positions, m.tool_offset)
        j = ROTATIONS.index(m.meta["rotation"])
        Jo = sp.csr_matrix(Jo)
        rows = Jo[j::3]
        J = rows - sp.csr_matrix(np.ones((m.n, 1))) @ rows[0]  # counted from the first row
        return RowBlock(sp.csr_matrix(J), np.asarray(m.deviation, dtype=float),
                        np.ones((m.n, 1)), [f"{m.id}:offset"])

    def plan(self, test: str, options: Any, only: str | None = None) -> list[Any]:
        from volcal.session.format import Measurement

        out = []
        for k, rot in ((0, "b"), (1, "a")):  # pitch of X, roll... of Y: one line each
            lo, hi = options.t[k] + np.array([1, -1]) * options.linear_margin_mm
            q = np.tile(options.t[:, 0], (options.steps + 1, 1))
            q[:, k] = np.linspace(lo, hi, options.steps + 1)
            mid = f"tilt-{'xyz'[k]}{rot}"
            out.append(Measurement(mid, self.name, "tilt_sensor", q, None, np.eye(3)[k],
                                   options.off, f"{mid}.csv", {}, {"axis": "xyz"[k],
                                                                   "rotation": rot}))
        return out

    def evaluate(self, m: Any) -> dict[str, Any] | None:
        return {"range_urad": float(np.ptp(m.deviation))}

    def report_section(self, inp: Any) -> Any:
        from volcal.report.document import Section, Table

        ms = [m for m in inp.session.measurements if m.kind == self.name]
        rows = []
        for m in ms:
            resid = None if inp.result is None else inp.result.residuals.get(m.id)
            rms = "-" if resid is None else f"{np.sqrt(np.mean(np.square(resid))):.2f}"
            rows.append([m.id, m.meta["axis"].upper(), m.meta["rotation"].upper(),
                         f"{self.evaluate(m)['range_urad']:.2f}", rms])
        sec = Section("tilt", "Tilt sensor")
        sec.tables.append(Table(["measurement", "axis", "rotation", "range [µrad]",
                                 "residual RMS [µrad]"], rows, "Tilt readings"))
        return sec


@pytest.fixture
def tilt_kind():
    kind = register_kind(TiltKind)
    yield kind
    unregister_kind(kind.name)


def test_the_test_kind_passes_the_contract(tilt_kind, tmp_path):
    assert kind_names()[-1] == "tilt"
    check_first_order(tilt_kind, lambda: planned_session(tilt_kind))
    check_round_trip(tilt_kind, planned_session(tilt_kind), tmp_path)
    check_refusals(tilt_kind, tmp_path / "s")


def test_a_bad_key_of_the_test_kind_is_refused_by_its_reader(tilt_kind, tmp_path):
    check_round_trip(tilt_kind, planned_session(tilt_kind), tmp_path)
    toml = tmp_path / "s" / "session.toml"
    toml.write_text(toml.read_text().replace('rotation = "b"', 'rotation = "q"', 1))
    with pytest.raises(VolcalInputError) as exc:
        from volcal.session.format import read_session

        read_session(tmp_path / "s")
    assert (exc.value.file, exc.value.column) == (str(toml), "measurements[0].rotation")
    assert "rotation must be one of a, b, c, got 'q'" in exc.value.message


def test_a_kind_of_the_test_goes_through_plan_simulate_identify_report(
        tilt_kind, tmp_path, monkeypatch, capsys):
    from volcal.identify.api import identify
    from volcal.identify.modelfile import load_model
    from volcal.report.html import render_html
    from volcal.report.pipeline import collect_inputs
    from volcal.report.sections import build_report
    from volcal.session.errortable import read_error_table
    from volcal.session.format import read_session

    s = tmp_path / "s"
    code, out, err = run_volcal(monkeypatch, capsys, "plan", "-o", str(s), "--travel",
                                "0:400,0:300,0:200", "--steps", "8", "--runs", "2",
                                "--tests", "linear,diagonal,tilt")
    assert code == 0, err
    toml = (s / "session.toml").read_text()
    assert toml.count('kind = "tilt"') == 2 and "tilt_urad" in (s / "tilt-xb.csv").read_text()
    code, out, err = run_volcal(monkeypatch, capsys, "program", str(s), "--dialect",
                                "linuxcnc", "-o", str(tmp_path / "prog"))
    assert code == 0, err
    ngc = (tmp_path / "prog" / "tilt_xb.ngc").read_text()
    assert ngc.count("G4 P4") == 9 and "TILT SENSOR" in ngc  # a dwell per planned reading
    code, out, err = run_volcal(monkeypatch, capsys, "simulate", str(s), "--seed", "3")
    assert code == 0, err
    session = read_session(s)
    tilts = [m for m in session.measurements if m.kind == "tilt"]
    assert [m.id for m in tilts] == ["tilt-xb", "tilt-ya"]
    truth = read_error_table(s / "truth" / "machine.csv")
    for m in tilts:  # the readings are the kind's forward model of the hidden truth + noise
        assert np.max(np.abs(m.deviation - tilt_kind.exact(truth, m))) < 5 * 0.5
        assert np.ptp(m.deviation) > 5.0
    code, out, err = run_volcal(monkeypatch, capsys, "identify", str(s), "-o",
                                str(tmp_path / "model.json"))
    assert code == 0, err
    result = load_model(tmp_path / "model.json")
    # the tilt readings are used: the model reproduces them to the noise, and EBX (the pitch
    # of X, which the tilt sensor reads along X) is identified close to the truth
    for m in tilts:
        r = result.residuals[m.id]
        assert r.shape == (m.n,) and np.sqrt(np.mean(r**2)) < 1.5 * 0.5
    x = tilts[0].positions[:, 0]
    ebx = result.errors.function("EBX", x) - result.errors.function("EBX", x[:1])
    ebx_true = truth.function("EBX", x) - truth.function("EBX", x[:1])
    assert np.max(np.abs(ebx - ebx_true)) < 1.5
    without = identify(read_session(s).__class__(
        session.name, session.chain, session.travel,
        [m for m in session.measurements if m.kind != "tilt"], session.meta, s))
    u_with = result.function_std("EBX", x[-1:])[0]
    u_without = without.function_std("EBX", x[-1:])[0]
    assert u_with < 0.5 * u_without  # the tilt sensor adds what the other tests lack
    report = build_report(collect_inputs(session, result, model_uncertainty=False))
    ids = [sec.id for sec in report.sections]
    assert "tilt" in ids and ids.index("tilt") < ids.index("identification")
    table = report.sections[ids.index("tilt")].tables[0]
    assert [r[0] for r in table.rows] == ["tilt-xb", "tilt-ya"]
    assert float(table.rows[0][3]) == pytest.approx(np.ptp(tilts[0].deviation), abs=0.006)
    assert float(table.rows[0][4]) == pytest.approx(
        np.sqrt(np.mean(result.residuals["tilt-xb"] ** 2)), abs=0.006)
    # the HTML's text, its figures blank (report_stubs.blank_figure): the kind adds a
    # section and no figure; the report's figures are the standard ones, built above from
    # this session and result, and drawn by tests/report (drawing them here: 4-5 s)
    from report_stubs import blank_figure

    for f in report.figures:
        f.figure = blank_figure(f.figure)
    html = render_html(report)
    assert "Tilt sensor" in html and "tilt-ya" in html
    measured = report.sections[ids.index("measurements")].tables[0]
    assert sum(r[1] == "tilt" for r in measured.rows) == 2


def test_unregistered_the_kind_is_refused_again(tmp_path):
    from volcal.plan.planner import plan_session

    assert "tilt" not in kind_names()
    with pytest.raises(VolcalInputError, match="unknown test"):
        plan_session([[0, 400], [0, 300], [0, 200]], tests=("tilt",))
