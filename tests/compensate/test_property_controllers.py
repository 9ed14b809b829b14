"""Property: model -> table -> the controller's interpolation rule -> the compensated
error equals the model error minus the table's error estimate, within the resolution and
the interpolation error of the table, for every pitch format and both signs."""

import tempfile
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from volcal.compensate import CompensationOptions, write_compensation
from volcal.compensate.fanuc import read_fanuc
from volcal.compensate.formats import DEFAULT_SIGN
from volcal.compensate.generic import CSV_FILE, read_generic
from volcal.compensate.heidenhain import read_heidenhain
from volcal.compensate.linuxcnc import read_linuxcnc
from volcal.compensate.siemens import LEC_FILE, read_lec
from volcal.measure.virtual import random_machine

TRAVEL = np.array([[0.0, 500.0], [0.0, 300.0], [0.0, 200.0]])


def _tables(fmt, folder, sign):
    """Tables as (positions [mm], error estimate [um], resolution [um], rule)."""
    s = 1.0 if sign == "error" else -1.0
    if fmt == "linuxcnc":  # trims are added to the command: estimate = -trim
        return [(f.positions, -f.values, f.resolution_um, "linear")
                for f, _ in read_linuxcnc(folder)]
    if fmt == "fanuc":
        return [(t.positions, s * t.values, t.resolution_um, "fanuc")
                for t in read_fanuc(folder, sign)]
    read = {"csv": lambda: read_generic(folder / CSV_FILE),
            "siemens": lambda: read_lec(folder / LEC_FILE, sign),
            "heidenhain": lambda: read_heidenhain(folder, sign)}[fmt]
    return [(t.positions, s * t.values, t.resolution_um, "linear") for t in read()]


def _apply(p, v, rule, c):
    if rule == "linear":  # Siemens, Heidenhain, LinuxCNC: linear, end values held
        return np.interp(c, p, v)
    # Fanuc: the increment of a section is output as pulses while the axis crosses it;
    # modelled as a step at the start of the section (worst case for the bound below)
    i = np.clip(np.searchsorted(p, c, side="right") - 1, 0, p.size - 1)
    return v[i]


@settings(max_examples=12, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 10_000), spacing=st.sampled_from([10.0, 20.0, 25.0]),
       fmt=st.sampled_from(["csv", "siemens", "heidenhain", "linuxcnc", "fanuc"]),
       sign=st.sampled_from([None, "error", "correction"]))
def test_compensated_error_is_model_minus_table(seed, spacing, fmt, sign):
    m = random_machine(TRAVEL, "XYFZ", seed, n_nodes=7)
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d) / "out"
        opts = CompensationOptions(sign, spacing=spacing, magnification=1)
        if fmt == "fanuc":
            opts = CompensationOptions(sign, spacing=spacing, max_increment=10_000)
        write_compensation(m, fmt, folder, opts)
        tables = _tables(fmt, folder, sign or DEFAULT_SIGN[fmt])
    for k, (p, est, res, rule) in enumerate(tables):
        c = np.linspace(*TRAVEL[k], 401)
        err = m.component(k, c)[:, k]
        fine = m.component(k, np.arange(TRAVEL[k, 0], TRAVEL[k, 1] + 0.5, 0.5))[:, k]
        curv = np.max(np.abs(np.diff(fine, 2))) / 0.25  # [um/mm^2]
        left = err - _apply(p, est, rule, c)
        if rule == "fanuc":  # zero at the reference: compare up to that constant
            left = left - (err[0] - est[np.argmin(np.abs(p - c[0]))])
            bound = res + np.max(np.abs(np.diff(est))) + 1e-9
        else:
            bound = res / 2 + curv * spacing ** 2 / 8 + 1e-9
        assert np.max(np.abs(left)) <= bound, (fmt, k)
