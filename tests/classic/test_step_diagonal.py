import numpy as np
import pytest

from volcal.classic.step_diagonal import solve_step_diagonals, step_diagonal_session
from volcal.errors import VolcalInputError
from volcal.measure.readings import (
    SetupErrors,
    perpendicular_basis,
    reading_exact,
    reading_first_order,
)
from volcal.measure.virtual import random_machine
from volcal.model.names import COMPONENT_NAMES
from volcal.plan.planner import plan_session

from .conftest import TRAVEL, no_angles

TRANSLATIONS = [n for n in COMPONENT_NAMES if n[1] in "XYZ"]


def _session(chain, machine, steps=10, tests=("step-diagonal",), tilts=None, exact=False):
    s = plan_session(TRAVEL, chain, steps, tests=tests)
    for i, m in enumerate(s.measurements):
        if exact:
            m.deviation = reading_exact(machine, m, SetupErrors(np.zeros(3), np.zeros(3),
                                                                align_beam=False))
        else:
            m.deviation = reading_first_order(machine, m, None if tilts is None else tilts[i])
    return s


def _errors_at_nodes(result, truth):
    """Max |estimate - truth| per translation function at the solver's nodes [um]."""
    out = {}
    for name in TRANSLATIONS:
        k = "XYZ".index(name[2])
        q = result.errors.nodes[k]
        out[name] = float(np.abs(result.errors.function(name, q) - truth.function(name, q)).max())
    return out


@pytest.mark.parametrize("chain, seed", [("XYFZ", 1), ("FXYZ", 2), ("XFYZ", 3), ("YFXZ", 4)])
def test_exact_recovery_without_angular_errors(chain, seed):
    truth = no_angles(random_machine(TRAVEL, chain, seed))
    r = step_diagonal_session(_session(chain, truth))
    err = _errors_at_nodes(r, truth)
    assert max(err.values()) < 1e-9, err
    np.testing.assert_allclose(r.errors.squareness, truth.squareness, atol=1e-9)
    assert r.residual_rms_um < 1e-9
    assert all(r.determined.values())
    assert r.n_increments == 4 * 3 * 10
    np.testing.assert_allclose(r.rigid_rotation_urad, 0.0, atol=1e-9)
    for v in r.errors.values:
        assert np.all(v[:, 3:] == 0.0)
        np.testing.assert_allclose(v[0, :3], 0.0, atol=1e-12)


def test_exact_reading_model_within_second_order():
    # exact homogeneous-transform readings, beam and mirror on the nominal diagonal:
    # the only model error is second order, ~ squareness^2 * travel = (50e-6)^2 * 1 m
    # = 2.5e-3 um plus the flat-mirror cosine terms of the same order.
    truth = no_angles(random_machine(TRAVEL, "XYFZ", 6))
    r = step_diagonal_session(_session("XYFZ", truth, exact=True))
    err = _errors_at_nodes(r, truth)
    assert max(err.values()) < 1e-2, err
    np.testing.assert_allclose(r.errors.squareness, truth.squareness, atol=0.05)


def test_face_step_diagonals_four_equations_four_unknowns():
    truth = no_angles(random_machine(TRAVEL, "XYFZ", 9))
    s = _session("XYFZ", truth, tests=("face-step-diagonal",))
    xy = [m for m in s.measurements if m.meta.get("plane") == "xy"]
    r = solve_step_diagonals(xy, "XYFZ", TRAVEL)
    assert r.residual_rms_um < 1e-12  # exactly determined
    assert r.determined == {**{n: n in ("EXX", "EYX", "EXY", "EYY") for n in TRANSLATIONS},
                            "EC0Y": True, "EB0Z": False, "EA0Z": False}
    err = _errors_at_nodes(r, truth)
    for n in ("EXX", "EYX", "EXY", "EYY"):
        assert err[n] < 1e-9
    assert r.errors.squareness[0] == pytest.approx(truth.squareness[0], abs=1e-9)
    # all three planes: every translation and squareness
    r3 = step_diagonal_session(s)
    assert all(r3.determined.values())
    assert max(_errors_at_nodes(r3, truth).values()) < 1e-9
    np.testing.assert_allclose(r3.errors.squareness, truth.squareness, atol=1e-9)


def test_mirror_misalignment_biases_the_positioning_slope_only():
    # Soons 2005 eq. 19-20: a mirror tilt tau (perpendicular to the beam) adds
    # tau . (q - q0) to every reading; for the X increments of diagonal s this is
    # tau_s,x * dx = tau_s,x * s_x * |dx| (s_x: travel sign of X in diagonal s), so EXX(end)
    # is off by  dX * mean_s(s_x tau_s,x) / n_x  (and Y, Z alike),
    # while straightness stays exact (the trend goes to squareness / rigid rotation).
    truth = no_angles(random_machine(TRAVEL, "XYFZ", 12))
    s0 = plan_session(TRAVEL, "XYFZ", 10, tests=("step-diagonal",))
    rng = np.random.default_rng(3)
    tilts = [rng.normal(0, 20, 2) for _ in s0.measurements]
    s = _session("XYFZ", truth, tilts=tilts)
    r = step_diagonal_session(s)
    tau = np.array([t @ perpendicular_basis(m.beam_direction)
                    for t, m in zip(tilts, s.measurements, strict=True)])
    signs = np.array([np.sign(m.beam_direction) for m in s.measurements])
    n_abs = np.abs(s.measurements[0].beam_direction)
    span = TRAVEL[:, 1] - TRAVEL[:, 0]
    for k, name in enumerate(("EXX", "EYY", "EZZ")):
        q = r.errors.nodes[k]
        bias = r.errors.function(name, q) - truth.function(name, q)
        mean_tau = (signs[:, k] * tau[:, k]).mean()
        predicted = (q - q[0]) * mean_tau / n_abs[k] * 1e-3
        np.testing.assert_allclose(bias, predicted, atol=1e-9)
        assert abs(bias[-1]) == pytest.approx(abs(span[k] * mean_tau / n_abs[k]) * 1e-3)
    err = _errors_at_nodes(r, truth)
    assert max(v for n, v in err.items() if n[1] != n[2]) < 1e-9
    assert max(err["EXX"], err["EYY"], err["EZZ"]) > 1.0  # um: visible, undetectable


def angular_bias_table(scales=(0.0, 1.0, 5.0, 10.0, 30.0), seeds=range(10), chain="XYFZ"):
    """RMS over seeds of the max errors of the classic solution vs peak-to-valley angular
    error [urad]; the random machines' angular functions are rescaled to that p-v."""
    rows = []
    for pv in scales:
        pos, strt, sq = [], [], []
        for seed in seeds:
            base = random_machine(TRAVEL, chain, seed)
            m = base.copy()
            for v in m.values:
                ptp = np.ptp(v[:, 3:], axis=0)
                v[:, 3:] *= np.where(ptp > 0, pv / np.where(ptp > 0, ptp, 1.0), 0.0)
            r = step_diagonal_session(_session(chain, m))
            e = _errors_at_nodes(r, m)
            pos.append(max(e["EXX"], e["EYY"], e["EZZ"]))
            strt.append(max(v for n, v in e.items() if n[1] != n[2]))
            sq.append(np.abs(r.errors.squareness - m.squareness).max())
        rms = [float(np.sqrt(np.mean(np.square(x)))) for x in (pos, strt, sq)]
        rows.append((pv, *rms))
    return rows


def format_bias_table(rows):
    lines = ["| angular errors p-v [urad] | positioning error [um] | straightness error [um] "
             "| squareness error [urad] |", "|---:|---:|---:|---:|"]
    for pv, p, s, q in rows:
        lines.append(f"| {pv:g} | {p:.2f} | {s:.2f} | {q:.1f} |")
    return "\n".join(lines)


def test_angular_errors_bias_is_linear_and_documented():
    rows = angular_bias_table()
    assert rows[0][1:] == pytest.approx((0.0, 0.0, 0.0), abs=1e-9)
    # first-order readings: the bias is proportional to the angular errors
    for pv, *b in rows[1:]:
        assert np.allclose(np.array(b) / pv, np.array(rows[1][1:]) / rows[1][0], rtol=1e-6)
    assert rows[-1][1] > 1.0  # at 30 urad the positioning bias exceeds 1 um
    from pathlib import Path
    doc = (Path(__file__).parents[2] / "docs" / "classic.md").read_text(encoding="utf-8")
    assert format_bias_table(rows) in doc


def test_two_axes_moving_together_is_reported_with_row():
    truth = no_angles(random_machine(TRAVEL, "XYFZ", 1))
    s = _session("XYFZ", truth)
    m = s.measurements[0]
    m.positions[3, 0] += 5.0  # row 4 of the data = CSV row 5: moves x and z
    with pytest.raises(VolcalInputError, match="row 5.*one axis at a time"):
        step_diagonal_session(s)


def test_missing_diagonal_is_reported():
    truth = no_angles(random_machine(TRAVEL, "XYFZ", 1))
    s = _session("XYFZ", truth)
    with pytest.raises(VolcalInputError, match="cannot separate"):
        solve_step_diagonals(s.measurements[:2], "XYFZ", TRAVEL)
