"""Wang & Liotto (seed 000) body-diagonal formulas, eq. (1)-(4), chain FXYZ.

Wang writes the diagonal reading as a sum of the 9 linear errors projected on the beam
plus angular terms with *constant* weights (ac/r, ab/r, bc/r). The lever arms of the
angular errors are the axis positions y and z, which grow along the diagonal: at
increment i they are i*b and i*c, so the weights are i*ac/r ... ("corrected eq. 1").
For npp, pnp and ppn the lever arms are the absolute positions, not the distances from
the start corner, which adds terms Wang's eqs. (3)-(4) lack. See docs/errata.md.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import TRAVEL, machine, meas, only
from volcal.measure.readings import SetupErrors, reading_exact, reading_first_order
from volcal.plan.geometry import diagonal_test

N = 10
X, Y, Z = TRAVEL[:, 1]
A, B, C = X / N, Y / N, Z / N
R = np.sqrt(A * A + B * B + C * C)
K = 1e-3  # urad * mm -> um


def _f(m, name, q):
    return m.function(name, q[:, "XYZ".index(name[-1])])


def _wang_squareness(m):
    """Wang's squareness symbols as lengths at the end of travel [um] (see conventions)."""
    c0y, b0z, a0z = m.squareness
    return -c0y * Y * K, b0z * Z * K, -a0z * Z * K  # O_xy, O_zx, O_yz


def wang_eq1(m, q, growing: bool):
    """Wang eq. (1), DR_ppp at every point; ``growing`` multiplies the angular weights by i."""
    i = np.arange(q.shape[0]) if growing else np.ones(q.shape[0])
    y, z = q[:, 1], q[:, 2]
    oxy, ozx, oyz = _wang_squareness(m)
    f = {n: _f(m, n, q) for n in ("EXX", "EYX", "EZX", "EXY", "EYY", "EZY", "EXZ", "EYZ",
                                  "EZZ", "EBX", "ECX", "EBY", "EAY")}
    return (A / R * f["EXX"] + B / R * f["EYX"] + C / R * f["EZX"]
            + A / R * (f["EXY"] + y / Y * oxy) + B / R * f["EYY"] + C / R * f["EZY"]
            + A / R * (f["EXZ"] + z / Z * ozx) + B / R * (f["EYZ"] + z / Z * oyz)
            + C / R * f["EZZ"]
            + K * i * (f["EBX"] * A * C / R - f["ECX"] * A * B / R + f["EBY"] * A * C / R
                       - f["EAY"] * B * C / R))


def corrected_diagonal(m, q, n):
    """Any body diagonal, FXYZ: lever arms are the absolute positions y, z (Soons eq. 1)."""
    def e(qq):
        y, z = qq[:, 1], qq[:, 2]
        f = {nm: _f(m, nm, qq) for nm in ("EXX", "EYX", "EZX", "EXY", "EYY", "EZY", "EXZ",
                                           "EYZ", "EZZ", "EAX", "EBX", "ECX", "EAY", "EBY")}
        c0y, b0z, a0z = m.squareness
        ex = (f["EXX"] + f["EXY"] + f["EXZ"] + K * ((f["EBX"] + f["EBY"]) * z - f["ECX"] * y)
              + K * (-c0y * y + b0z * z))
        ey = f["EYX"] + f["EYY"] + f["EYZ"] - K * (f["EAX"] + f["EAY"]) * z - K * a0z * z
        ez = f["EZX"] + f["EZY"] + f["EZZ"] + K * f["EAX"] * y
        return np.c_[ex, ey, ez] @ n
    v = e(q)
    return v - v[0]


def _diag(code):
    g = diagonal_test(code, TRAVEL, N)
    return g.positions, g.beam_direction


def test_corrected_eq1_matches_model():
    m = machine("FXYZ", seed=21)
    q, n = _diag("ppp")
    ms = meas(q, "retroreflector", n, kind="diagonal")
    model = reading_first_order(m, ms)
    np.testing.assert_allclose(wang_eq1(m, q, growing=True), model, atol=1e-9)
    np.testing.assert_allclose(reading_exact(m, ms, SetupErrors.none()), model, atol=1e-3)
    # as printed (constant weights) eq. (1) holds at the first increment only
    printed = wang_eq1(m, q, growing=False)
    assert printed[1] == pytest.approx(model[1], abs=1e-9)
    assert np.abs(printed[2:] - model[2:]).max() > 0.1


@pytest.mark.parametrize("name,weight", [("EBX", A * C), ("ECX", -A * B), ("EBY", A * C),
                                         ("EAY", -B * C), ("EAX", 0.0), ("ECY", 0.0),
                                         ("EAZ", 0.0), ("EBZ", 0.0), ("ECZ", 0.0)])
def test_which_angular_errors_enter_ppp(name, weight):
    """Each angular error alone (constant 10 urad): DR_ppp(i) = i * weight / r * 10 urad."""
    m = only(machine("FXYZ").scaled(0.0), {name: 10.0})
    q, n = _diag("ppp")
    got = reading_exact(m, meas(q, "retroreflector", n, kind="diagonal"), SetupErrors.none())
    np.testing.assert_allclose(got, np.arange(N + 1) * weight / R * 10.0 * K, atol=1e-4)


@pytest.mark.parametrize("code", ["ppp", "npp", "pnp", "ppn"])
def test_corrected_formula_all_diagonals(code):
    m = machine("FXYZ", seed=22)
    q, n = _diag(code)
    ms = meas(q, "retroreflector", n, kind="diagonal")
    np.testing.assert_allclose(corrected_diagonal(m, q, n), reading_first_order(m, ms),
                               atol=1e-9)
    np.testing.assert_allclose(corrected_diagonal(m, q, n),
                               reading_exact(m, ms, SetupErrors.none()), atol=1e-3)


def test_roll_of_x_enters_pnp_and_ppn():
    """Erratum: X roll enters pnp with weight +cY/r and ppn with -bZ/r (eqs. 3-4 omit it)."""
    base = machine("FXYZ").scaled(0.0)
    x = base.nodes[0]
    m = only(base, {"EAX": 20.0 * np.sin(np.pi * x / X)})
    for code, weight in (("ppp", 0.0), ("npp", 0.0), ("pnp", C * Y), ("ppn", -B * Z)):
        q, n = _diag(code)
        got = reading_exact(m, meas(q, "retroreflector", n, kind="diagonal"),
                            SetupErrors.none())
        d_eax = _f(m, "EAX", q) - _f(m, "EAX", q[:1])
        np.testing.assert_allclose(got, weight / R * d_eax * K, atol=1e-4)
        if weight:
            assert np.abs(got).max() > 0.5  # um: not negligible on a 1 m machine


def test_same_structure_for_xfyz_and_xyfz():
    """Erratum: Wang's different angular terms for XFYZ and XYFZ do not hold; with errors
    defined as tool-relative-to-workpiece motions, FXYZ, XFYZ and XYFZ read the same."""
    q, n = _diag("ppp")
    ms = meas(q, "retroreflector", n, kind="diagonal")
    ref = reading_exact(machine("FXYZ", seed=4), ms, SetupErrors.none())
    for chain in ("XFYZ", "XYFZ"):
        np.testing.assert_array_equal(reading_exact(machine(chain, seed=4), ms,
                                                    SetupErrors.none()), ref)
    # and Wang's XYFZ term Ax(x)*bc/r is absent: X roll alone does not move DR_ppp
    m = only(machine("XYFZ").scaled(0.0), {"EAX": 10.0})
    np.testing.assert_allclose(reading_exact(m, ms, SetupErrors.none()), 0.0, atol=1e-9)


def test_step_diagonal_factor_f_and_h():
    """Erratum: Wang's f = sqrt((4a^2+b^2+c^2)/(b^2+c^2)) (eq. 5) and h = sqrt(4a^2+b^2)/b
    (eq. 19). After the x move of increment i+1 of the ppp step diagonal (flat mirror),
    an X pitch EBX reads (a/r) * (i+1) * c * EBX: lever z = i*c plus the beam spot's
    offset a on the mirror (Soons eq. 4), i.e. f = (i+1) a / r, not a constant."""
    from volcal.plan.geometry import step_diagonal_test

    nominal_beam = SetupErrors(np.zeros(3), np.zeros(3), align_beam=False)
    base = machine("FXYZ").scaled(0.0)
    m = only(base, {"EBX": 30.0 * base.nodes[0] / X})  # pitch growing to 30 urad
    g = step_diagonal_test("ppp", TRAVEL, N, "xyz")
    r = reading_exact(m, meas(g.positions, "flat_mirror", g.beam_direction), nominal_beam)
    i = np.arange(N)
    after_x = 1 + 3 * i
    ebx = _f(m, "EBX", g.positions[after_x])
    np.testing.assert_allclose(r[after_x], A / R * (i + 1) * C * ebx * K, atol=1e-3)
    f = np.sqrt((4 * A**2 + B**2 + C**2) / (B**2 + C**2))
    assert np.abs(r[after_x] - f * C * ebx * K).max() > 0.5
    # face diagonal xy, yaw ECX: -(a b / r) (i+1) ECX, against Wang's -h b ECX
    m = only(base, {"ECX": 30.0 * base.nodes[0] / X})
    g = step_diagonal_test("pp", TRAVEL, N, "xy", plane="xy")
    r = reading_exact(m, meas(g.positions, "flat_mirror", g.beam_direction), nominal_beam)
    rf = np.hypot(A, B)
    after_x = 1 + 2 * i
    ecx = _f(m, "ECX", g.positions[after_x])
    np.testing.assert_allclose(r[after_x], -A * B / rf * (i + 1) * ecx * K, atol=1e-3)
    h = np.sqrt(4 * A**2 + B**2) / B
    assert np.abs(r[after_x] - (-h * B * ecx * K)).max() > 0.5


def test_wang_squareness_symbols_follow_eq1():
    """Only squareness: eq. (1)'s terms a/r*y/Y*Oxy + a/r*z/Z*Ozx + b/r*z/Z*Oyz with the
    mapping of volcal.model.names.WANG_SYMBOLS reproduce the model."""
    from volcal.model.names import WANG_SYMBOLS

    assert (WANG_SYMBOLS["EC0Y"], WANG_SYMBOLS["EB0Z"], WANG_SYMBOLS["EA0Z"]) == \
        ("-Oxy/Y", "Ozx/Z", "-Oyz/Z")
    m = machine("FXYZ").scaled(0.0)
    m.squareness[:] = [40.0, -25.0, 30.0]
    q, n = _diag("ppp")
    oxy, ozx, oyz = -40.0 * Y * K, -25.0 * Z * K, -30.0 * Z * K
    y, z = q[:, 1], q[:, 2]
    wang = A / R * y / Y * oxy + A / R * z / Z * ozx + B / R * z / Z * oyz
    got = reading_first_order(m, meas(q, "retroreflector", n, kind="diagonal"))
    np.testing.assert_allclose(got, wang, atol=1e-9)
