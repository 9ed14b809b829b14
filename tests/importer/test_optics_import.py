"""`volcal import --measurement` of direct optics: angle units, --sign, --slope-removed."""

from __future__ import annotations

import numpy as np
import pytest

from volcal.errors import ParameterError, VolcalInputError
from volcal.importer.optics import ANGLE_TO_URAD, angle_unit, parse_sign
from volcal.importer.planned import import_planned
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.plan.planner import plan_session
from volcal.session.format import read_session, write_session

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])


@pytest.fixture
def planned(tmp_path):
    s = plan_session(TRAVEL, "XYFZ", 4, ("direct",), runs=1)
    write_session(s, tmp_path / "s")
    truth = plan_session(TRAVEL, "XYFZ", 4, ("direct",), runs=1)
    simulate_session(truth, random_machine(TRAVEL, "XYFZ", seed=5), SimulationOptions(seed=1))
    return tmp_path / "s", {m.id: m for m in truth.measurements}


def _export(path, m, values, head="Position (mm);Error (mm);Run;Dir", preamble="XL-80 export\n"):
    k = m.axis
    lines = [f"{p[k]:.3f};{v:.9f};{r};{d}" for p, v, r, d in
             zip(m.positions, values, m.run, m.direction, strict=True)]
    path.write_text(preamble + head + "\n" + "\n".join(lines) + "\n", encoding="utf-8")
    return path


MAP = {"target": "Position", "deviation": "Error", "run": "Run", "direction": "Dir"}


def test_straightness_in_mm_with_the_other_sign(planned, tmp_path):
    """A vendor export of the workpiece side relative to the tool side, in mm: --sign -."""
    folder, truth = planned
    m = truth["str-yz"]
    f = _export(tmp_path / "e.csv", m, -m.deviation * 1e-3)
    r = import_planned(f, MAP, folder, "str-yz", sign=parse_sign("-"))
    np.testing.assert_allclose(r.measurement.deviation, m.deviation, atol=1e-6)
    back = read_session(folder, require_deviation=False).get("str-yz")
    np.testing.assert_allclose(back.deviation, m.deviation, atol=1e-6)
    assert any("sign reversed" in n for n in r.notes)


@pytest.mark.parametrize(("unit", "factor"), [("arcsec", 4.84813681109536), ("mm/m", 1000.0),
                                               ("urad", 1.0), ("um/m", 1.0)])
def test_angle_units_from_the_header(planned, tmp_path, unit, factor):
    folder, truth = planned
    m = truth["ang-xb"]
    f = _export(tmp_path / "a.csv", m, m.deviation / factor,
                head=f"Position (mm);Error ({unit});Run;Dir")
    r = import_planned(f, MAP, folder, "ang-xb", replace=True)
    np.testing.assert_allclose(r.measurement.deviation, m.deviation, atol=1e-5)
    assert ANGLE_TO_URAD[angle_unit("auto", f"x ({unit})")] == pytest.approx(factor)


def test_angle_without_unit_needs_the_option(planned, tmp_path):
    folder, truth = planned
    m = truth["lev-xa"]
    f = _export(tmp_path / "a.csv", m, m.deviation, head="Position (mm);Error;Run;Dir")
    with pytest.raises(VolcalInputError, match="no angle unit"):
        import_planned(f, MAP, folder, "lev-xa")
    r = import_planned(f, MAP, folder, "lev-xa", deviation_units="urad")
    np.testing.assert_allclose(r.measurement.deviation, m.deviation, atol=1e-6)
    with pytest.raises(VolcalInputError, match="not an angle unit"):
        import_planned(f, MAP, folder, "lev-xa", deviation_units="um", replace=True)


def test_slope_removed_is_recorded_and_refused_in_a_group(planned, tmp_path):
    folder, truth = planned
    m = truth["str-xy"]
    f = _export(tmp_path / "e.csv", m, m.deviation * 1e-3)
    with pytest.raises(VolcalInputError, match="reference group 'xy'"):
        import_planned(f, MAP, folder, "str-xy", slope_removed=True)
    assert read_session(folder, require_deviation=False).get("str-xy").deviation is None
    with pytest.raises(ParameterError, match="sign='minus'") as e:
        parse_sign("minus")
    from volcal.cli._options import OPTIONS

    assert str(e.value.spelled(OPTIONS)).startswith("--sign 'minus': expected +")
