"""Renishaw dynamic capture (.rtx): reader, dwell detection and import into planned tests.

The captures are written here in the layout of the open readers (TanmayPani/rtx2csv,
travdt/RTX2CSV-Converter): ``HEADER::``, ``Key: value`` lines, ``Data:``, little-endian
float64 samples, ``EOF::``. The signal is known: a dwell at each planned pose holding the
planned reading, motion between the dwells (a ramp, an overrun excursion where two poses
coincide, a vibration and a settling ring), white noise. The per-pose means must equal the
known readings within the noise of a dwell's mean.
"""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from volcal.cli import app
from volcal.errors import VolcalInputError
from volcal.importer.rtx import find_dwells, read_rtx
from volcal.importer.rtx_import import import_rtx
from volcal.session.format import read_session

RATE = 1000.0  # [Hz]
DWELL = 1.0  # [s]
MOVE = 0.6  # [s]
runner = CliRunner()


def write_rtx(path, samples, rate=RATE, trailer=b"\r\nEOF::\r\n", declared=None, **extra):
    """A dynamic capture in the .rtx layout (header lines, Data:, float64 LE, EOF::)."""
    head = {"Filename": path.name, "Owner": "CARTO-Dynamic", "Version no": "4.13.0.0",
            "File Type": "rtx", "Velocity": "0", "Sample rate": f"{rate:g}",
            "Sample no": str(len(samples) if declared is None else declared),
            "Trigger point": "0", "Trigger interval": f"{1 / rate:g}",
            "Actual sample rate": f"{rate:g}", "Flags": "0 1 2 0 2", "Machine": "VMC-1",
            "Serial No": "123456", "Date": "24/11/2026 04:00:00", "By": "Tester",
            "Axis": "X", "Location": ""}
    head.update(extra)
    text = "".join(f"{k}: {v}\r\n" for k, v in head.items() if v is not None)
    data = np.asarray(samples, dtype="<f8").tobytes()
    path.write_bytes(b"HEADER::\r\n" + text.encode() + b"Data:\r\n" + data + trailer)
    return path


def capture(values, moves=None, noise=0.0, seed=0, lead_s=0.0):
    """Samples: a dwell at each value, a move (ramp + vibration + overrun) between them.

    Parameters
    ----------
    values : array
        The still reading at each pose [capture unit].
    moves : array, optional
        Extra excursion of each move (an overrun where two poses coincide).
    noise : float
        Standard deviation of the white noise [capture unit].
    """
    rng = np.random.default_rng(seed)
    nd, nm = int(DWELL * RATE), int(MOVE * RATE)
    vib = 0.2 * max(noise, 1e-3)
    parts = [np.full(int(lead_s * RATE), values[0])]
    for i, v in enumerate(values):
        ring = vib * 3 * np.exp(-np.arange(nd) / (0.03 * RATE)) * np.sin(
            2 * np.pi * 40 * np.arange(nd) / RATE)  # settling after the stop
        parts.append(v + ring)
        if i + 1 < len(values):
            s = np.linspace(0, 1, nm)
            ramp = v + (values[i + 1] - v) * s
            if moves is not None:
                ramp = ramp + moves[i] * np.sin(np.pi * s)
            parts.append(ramp + 5 * vib * np.sin(2 * np.pi * 15 * s * MOVE))
    x = np.concatenate(parts)
    return x + rng.normal(0.0, noise, x.size)


def _within_noise(got, want, noise):
    # a dwell's mean has the noise / sqrt(samples averaged); 1 s at 1 kHz, ~0.6 kept
    tol = 5 * noise / np.sqrt(0.5 * DWELL * RATE) + 1e-9
    np.testing.assert_allclose(got, want, atol=tol)


def _plan(tmp_path, tests="direct:x"):
    s = tmp_path / "S"
    r = runner.invoke(app, ["plan", "-o", str(s), "--tests", tests, "--steps", "4", "--runs",
                            "1"])
    assert r.exit_code == 0, r.output
    return s


def _measurement(s, mid):
    ses = read_session(s, require_deviation=False)
    return next(m for m in [*ses.measurements, *ses.unmeasured] if m.id == mid)


def test_reader_layout_round_trip(tmp_path):
    x = np.random.default_rng(1).normal(size=1001)
    for trailer in (b"\r\nEOF::\r\n", b"EOF::\r\n", b""):
        c = read_rtx(write_rtx(tmp_path / "a.rtx", x, trailer=trailer))
        assert np.array_equal(c.samples, x)
        assert c.rate_hz == RATE and c.header["By"] == "Tester"
        assert c.header["Flags"] == "0 1 2 0 2"
    c = read_rtx(write_rtx(tmp_path / "b.rtx", x, declared=None, **{"Sample no": None,
                                                                   "Actual sample rate": None}))
    assert np.array_equal(c.samples, x) and c.rate_hz == RATE  # 'Sample rate' as fallback
    with pytest.raises(VolcalInputError, match="declares 2000 samples but the file holds 1001"):
        read_rtx(write_rtx(tmp_path / "c.rtx", x, declared=2000, trailer=b""))
    with pytest.raises(VolcalInputError, match="not the 'EOF::' trailer"):
        read_rtx(write_rtx(tmp_path / "d.rtx", x, declared=1000))
    (tmp_path / "e.rtx").write_text("Position,Error\n0,1\n")
    with pytest.raises(VolcalInputError, match="HEADER::") as e:
        read_rtx(tmp_path / "e.rtx")
    assert e.value.file.endswith("e.rtx")


def test_dwells_found_and_averaged():
    vals = np.array([0.0, 2.0, 2.3, -1.0, 0.5, 0.5, 4.0])  # two equal in a row: an overrun
    moves = np.array([0, 0, 0, 0, 1.5, 0])
    x = capture(vals, moves, noise=0.3, seed=2, lead_s=2.0)
    assert len(find_dwells(x, RATE, DWELL)) == 6  # 2.0 -> 2.3: a move of 1 noise sigma
    d = find_dwells(x, RATE, DWELL, n=len(vals))  # split where the step is
    assert len(d) == len(vals)
    _within_noise([q.mean for q in d], vals, 0.3)
    assert all(q.std < 0.4 for q in d)
    # dwell i ends (lead + (i + 1) dwells + i moves) s after the start; the samples
    # averaged lie inside it (the first joins the idle lead at the same reading; around
    # the step 2.0 -> 2.3, found by the split, up to a quarter of the move is taken)
    ends = 2.0 + DWELL * np.arange(1, 8) + MOVE * np.arange(7)
    late = np.array([0, MOVE / 4, 0, 0, 0, 0, 0])  # dwell 2's end may reach into the move
    early = np.array([0, 0, MOVE / 4, 0, 0, 0, 0])  # dwell 3's start too
    assert np.all(np.array([q.stop for q in d]) / RATE <= ends + late + 1e-9)
    starts = np.array([q.start for q in d]) / RATE
    assert np.all(starts[1:] >= (ends - DWELL - early)[1:])


def test_straightness_and_angle_captures_import(tmp_path):
    s = _plan(tmp_path)
    m = _measurement(s, "str-xy")
    rng = np.random.default_rng(3)
    dev_um = rng.uniform(-5, 5, m.n)
    f = write_rtx(tmp_path / "str.rtx", capture(0.0123 + dev_um / 1000, noise=2e-4, seed=4))
    r = runner.invoke(app, ["import", str(f), "--session", str(s), "--measurement", "str-xy",
                            "--dwell-s", "1"])
    assert r.exit_code == 0, r.output
    assert "10 readings of straightness str-xy" in " ".join(r.output.split())
    got = _measurement(s, "str-xy")
    _within_noise(got.deviation, dev_um - dev_um[0], 0.2)
    t = got.columns["time_s"]
    assert np.all(np.diff(t) > DWELL) and got.meta["import"]["layout"] == "rtx"
    assert got.columns["run"].tolist() == m.columns["run"].tolist()
    # an angle capture in mrad (the capture's unit) from an optic with the other sign
    a = _measurement(s, "ang-xb")
    ang_urad = rng.uniform(-20, 20, a.n)
    f = write_rtx(tmp_path / "ang.rtx", capture(-ang_urad / 1000, noise=1e-3, seed=5))
    r = import_rtx(f, s, "ang-xb", sign=-1.0, dwell_s=DWELL)
    _within_noise(r.measurement.deviation, ang_urad - ang_urad[0], 1.0)
    _within_noise(_measurement(s, "ang-xb").deviation, ang_urad - ang_urad[0], 1.0)
    # the Python flow: Calibration.import_ of a capture in um
    from volcal.flow import Calibration

    z_um = rng.uniform(-3, 3, m.n)
    f = write_rtx(tmp_path / "strz.rtx", capture(z_um, noise=0.2, seed=9))
    Calibration.import_(f, session=s, measurement="str-xz", deviation_units="um", dwell_s=1.0)
    _within_noise(_measurement(s, "str-xz").deviation, z_um - z_um[0], 0.2)


def test_linear_capture_deviation_from_the_plan(tmp_path):
    s = _plan(tmp_path)
    m = _measurement(s, "lin-x")
    travel = m.positions[:, 0]
    dev_um = np.random.default_rng(6).uniform(-8, 8, m.n)
    moves = np.where(np.diff(travel) == 0, 5.0, 0.0)  # the overrun at the reversal
    x = capture(100.0 + travel + dev_um / 1000, moves, noise=3e-4, seed=7)
    f = write_rtx(tmp_path / "lin.rtx", x)
    r = import_rtx(f, s, "lin-x", dwell_s=DWELL)
    _within_noise(r.measurement.deviation, dev_um - dev_um[0], 0.3)
    # readings in um: --units
    f2 = write_rtx(tmp_path / "lin-um.rtx", x * 1000)
    r2 = import_rtx(f2, s, "lin-x", units="um", dwell_s=DWELL, replace=True)
    np.testing.assert_allclose(r2.measurement.deviation, r.measurement.deviation, atol=1e-6)
    # an interferometer's own noise (10 nm) on readings of up to 900 mm
    x = capture(100.0 + travel + dev_um / 1000, moves, noise=1e-5, seed=8)
    r3 = import_rtx(write_rtx(tmp_path / "lin-fine.rtx", x), s, "lin-x", dwell_s=DWELL,
                    replace=True)
    _within_noise(r3.measurement.deviation, dev_um - dev_um[0], 0.01)


def test_refusals_name_the_file(tmp_path):
    s = _plan(tmp_path)
    m = _measurement(s, "lin-x")
    travel = m.positions[:, 0]
    f = write_rtx(tmp_path / "short.rtx", capture(travel[:7], noise=3e-4))
    with pytest.raises(VolcalInputError, match="7 dwells found .* planned with 10 poses") as e:
        import_rtx(f, s, "lin-x", dwell_s=DWELL)
    assert e.value.file.endswith("short.rtx")
    shuffled = travel[[0, 2, 1, 3, 4, 5, 6, 7, 8, 9]]
    moves = np.where(np.diff(shuffled) == 0, 5.0, 0.0)
    f = write_rtx(tmp_path / "order.rtx", capture(shuffled, moves, noise=3e-4))
    with pytest.raises(VolcalInputError, match="dwell 2 .* planned 211"):
        import_rtx(f, s, "lin-x", dwell_s=DWELL)
    with pytest.raises(VolcalInputError, match="--sign is for direct optics"):
        import_rtx(f, s, "lin-x", sign=-1.0, dwell_s=DWELL)
    r = runner.invoke(app, ["import", str(f), "--session", str(s), "--axis", "X", "--id", "l9"])
    assert isinstance(r.exception, VolcalInputError) and "--measurement" in str(r.exception)
    assert _measurement(s, "lin-x").deviation is None  # nothing written
