"""Raw-reading compensation, material expansion, drift check and the session hook."""

import numpy as np
import pytest

from volcal.environment.apply import compensate_measurement
from volcal.environment.compensation import compensate_readings
from volcal.environment.drift import drift_check
from volcal.environment.materials import expansion_coefficient, to_20c
from volcal.errors import VolcalInputError
from volcal.session.format import Measurement, Session, read_session, write_session

# NIST EMToolbox check value (Stone & Zimmerman, table of section VII): Ciddor, 20 degC,
# 101.325 kPa, 0 % RH, 633 nm, 450 umol/mol CO2 -> n = 1.000271800, printed to 1e-9, so
# tolerances are 1e-3 um on 1000 mm.
N_NIST = 1.000271800
AIR = dict(air_temperature_c=20.0, air_pressure_pa=101325.0, humidity_pct=0.0,
           wavelength_nm=633.0)


def test_wavelength_compensation_by_hand():
    # raw reading 1000 mm exactly (deviation 0): true displacement 1000 / n mm
    dev = compensate_readings([1000.0], [0.0], **AIR)
    assert dev[0] == pytest.approx((1000.0 / N_NIST - 1000.0) * 1e3, abs=1e-3)
    assert dev[0] == pytest.approx(-271.726, abs=1e-3)


def test_material_expansion_to_20c_by_hand():
    # steel scale at 21 degC: L20 = L / (1 + 11.5e-6)
    assert expansion_coefficient("Steel") == 11.5
    assert to_20c(1000.0, 21.0, 11.5) == pytest.approx(1000.0 / 1.0000115)
    dev = compensate_readings([1000.0], [0.0], material_temperature_c=21.0,
                              expansion_ppm_per_k=11.5, **AIR)
    assert dev[0] == pytest.approx((1000.0 / N_NIST / 1.0000115 - 1000.0) * 1e3, abs=1e-3)
    with pytest.raises(VolcalInputError, match="unknown material"):
        expansion_coefficient("unobtainium")


def test_drift_check():
    pos = np.array([[0, 0, 0], [100, 0, 0], [0, 0, 0], [100, 0, 0], [0, 0, 0]], float)
    dev = np.array([0.0, 5.0, 0.6, 5.0, 1.2])
    t = np.array([0.0, 900, 1800, 2700, 3600])
    r = drift_check(pos, dev, t, limit_um=1.0)
    assert r.n == 3
    assert r.rate_um_per_h == pytest.approx(1.2)
    assert r.span_um == pytest.approx(1.2) and not r.ok
    assert drift_check(pos, dev, limit_um=2.0).ok


def _raw_measurement(true_dev_um, env):
    n = 11
    pos = np.zeros((n, 3))
    pos[:, 0] = np.linspace(0, 800, n)
    c = pos[:, 0]
    # forward model of a raw reading: L_raw = n_air * (1 + alpha dT) * (C + dev)
    n_air = N_NIST
    raw = (c + true_dev_um * 1e-3) * n_air * (1 + 11.5e-6 * 1.0)
    meta = {"readings": "raw", "environment": env, "axis": "X"}
    return Measurement("lin", "linear", "retroreflector", pos, (raw - c) * 1e3,
                       [1, 0, 0], meta=meta)


ENV = {"air_temperature_c": 20.0, "air_pressure_pa": 101325.0, "humidity_pct": 0.0,
       "wavelength_nm": 633.0, "material_temperature_c": 21.0, "material": "steel"}


def test_compensate_measurement_recovers_truth():
    truth = np.sin(np.linspace(0, 3, 11)) * 4.0
    out = compensate_measurement(_raw_measurement(truth, ENV))
    np.testing.assert_allclose(out.deviation, truth, atol=1e-3)
    assert out.meta["readings"] == "compensated"


def test_read_session_applies_environment(tmp_path):
    truth = np.linspace(0, 6, 11)
    s = Session("m", "XYFZ", [[0, 800], [0, 600], [0, 500]], [_raw_measurement(truth, ENV)])
    write_session(s, tmp_path / "s")
    back = read_session(tmp_path / "s")
    np.testing.assert_allclose(back.measurements[0].deviation, truth, atol=1e-3)


def test_missing_environment_key_is_named(tmp_path):
    env = {k: v for k, v in ENV.items() if k != "air_pressure_pa"}
    with pytest.raises(VolcalInputError) as exc:
        compensate_measurement(_raw_measurement(np.zeros(11), env))
    assert exc.value.column == "environment.air_pressure_pa"
    bad = dict(ENV, air_pressure_hpa=1013.25)
    with pytest.raises(VolcalInputError, match="unknown key") as exc:
        compensate_measurement(_raw_measurement(np.zeros(11), bad))
    assert exc.value.column == "environment.air_pressure_hpa"


def test_environment_columns_take_precedence():
    truth = np.zeros(11)
    m = _raw_measurement(truth, dict(ENV, air_temperature_c=35.0))
    m.columns["air_temperature_c"] = np.full(11, 20.0)
    out = compensate_measurement(m)
    np.testing.assert_allclose(out.deviation, truth, atol=1e-3)
