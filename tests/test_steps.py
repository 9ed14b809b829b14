"""The step functions of volcal.steps on their own: what they compute and refuse.

One small virtual machine (600 x 400 x 300 mm, 4 increments, 2 runs) is planned,
simulated and identified once; the steps' results are checked against the library
functions they call and against the command line's text.
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from volcal.cli._options import OPTIONS
from volcal.errors import ParameterError, VolcalInputError
from volcal.steps import identify as identify_step
from volcal.steps import plan as plan_step
from volcal.steps import predict as predict_step
from volcal.steps import simulate as simulate_step

TRAVEL = [[0, 600], [0, 400], [0, 300]]


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    out = tmp_path_factory.mktemp("s") / "S"
    p = plan_step.plan(TRAVEL, steps=4, runs=2, name="ST-600", output=out)
    assert p.output == out and p.backup is None
    assert p.n_readings == sum(m.n for m in p.session.measurements) > 0
    r = simulate_step.simulate(out, seed=4, noise_um=0.2)
    assert r.replaced == () and r.notes == ()
    assert simulate_step.save(r, out) is None
    return out


@pytest.fixture(scope="module")
def identified(folder):
    return identify_step.identify(folder, monte_carlo=30)


def test_monte_carlo_summary_is_the_propagation_over_the_measured_grid(identified):
    from volcal.identify import monte_carlo
    from volcal.identify.identifiability import grid_points

    res, mc = identified.result, identified.monte_carlo
    q = grid_points(res.design)
    _, sd, lo, hi = monte_carlo(res, q, 30)  # the same seed (0): the same draws
    assert mc is not None and mc.trials == 30 and mc.points == q.shape[0]
    assert mc.max_std_um == pytest.approx(sd.max(), rel=1e-12)
    assert mc.rms_std_um == pytest.approx(np.sqrt(np.mean(sd**2)), rel=1e-12)
    assert mc.max_95_half_width_um == pytest.approx(((hi - lo) / 2).max(), rel=1e-12)
    assert 0 < mc.rms_std_um <= mc.max_std_um
    assert res.fit["monte_carlo"] == mc.to_dict()  # written into the model file
    assert identified.systematic is None and identified.notes == ()


def test_identify_refuses_an_unknown_measurement(folder):
    with pytest.raises(ParameterError) as e:
        identify_step.identify(folder, measurements="diag-ppp,nope")
    assert e.value.file == str(folder / "session.toml")
    assert e.value.message.startswith("measurements: no measurement nope in the session")
    assert str(e.value.spelled(OPTIONS)).startswith(
        f"{folder / 'session.toml'}: --measurements: no measurement nope in the session")


@pytest.mark.parametrize("kwargs,python,cli", [
    ({"noise_um": -1.0}, "noise_um=-1.0: expected a positive repeatability [um]",
     "--noise-um -1.0: expected a positive repeatability [um]"),
    ({"known_u": 2.0}, "known_u needs known (the error table it applies to)",
     "--known-u needs --known (the error table it applies to)"),
    ({"known": "k.csv", "known_u": 0.0}, "known_u=0.0: expected a positive uncertainty",
     "--known-u 0.0: expected a positive uncertainty"),
    ({"measurements": ","}, "measurements=',': no measurement id given",
     "--measurements ',': no measurement id given"),
])
def test_identify_names_the_parameter_before_reading_anything(kwargs, python, cli):
    with pytest.raises(ParameterError) as e:  # the session folder does not exist
        identify_step.identify("no-such-session", **kwargs)
    assert str(e.value) == python
    assert str(e.value.spelled(OPTIONS)) == cli


def test_simulate_refuses_measured_readings_unless_overwrite(folder, tmp_path):
    s = tmp_path / "m"
    shutil.copytree(folder, s)
    csv = next(p for p in s.glob("*.csv"))
    csv.write_text(csv.read_text().replace("0.", "1.", 1))  # edited: no longer simulated
    with pytest.raises(ParameterError) as e:
        simulate_step.simulate(s, seed=1)
    assert "Use overwrite=True to replace them" in str(e.value)
    assert "Use --overwrite to replace them" in str(e.value.spelled(OPTIONS))
    r = simulate_step.simulate(s, seed=1, overwrite=True)
    assert len(r.replaced) >= 1
    backup = simulate_step.save(r, s)
    assert backup is not None and (backup / csv.name).is_file()


def test_predict_from_a_file_or_an_array_is_the_models_prediction(identified, tmp_path):
    res = identified.result
    q = np.array([[0.0, 0.0, 0.0], [100.0, 50.0, 20.0], [600.0, 400.0, 300.0]])
    pts = tmp_path / "p.csv"
    pts.write_text("x_mm,y_mm,z_mm\n" + "".join(f"{a:g},{b:g},{c:g}\n" for a, b, c in q))
    res.to_json(tmp_path / "m.json")
    from_file = predict_step.predict(tmp_path / "m.json", pts, tool_offset=(0, 0, -50))
    from_array = predict_step.predict(res, q, tool_offset=(0, 0, -50))
    e, u = res.predict(q, np.array([0.0, 0.0, -50.0]))
    np.testing.assert_allclose(from_array.error_um, e, rtol=0, atol=1e-12)
    np.testing.assert_allclose(from_array.u_um, u, rtol=0, atol=1e-12)
    from volcal.identify import load_model

    e_file, u_file = load_model(tmp_path / "m.json").predict(q, np.array([0.0, 0.0, -50.0]))
    np.testing.assert_array_equal(from_file.error_um, e_file)
    np.testing.assert_array_equal(from_file.u_um, u_file)
    np.testing.assert_allclose(from_file.error_um, e, rtol=0, atol=1e-5)  # the file's digits
    rows = from_file.to_csv().splitlines()
    assert rows[0] == "x_mm,y_mm,z_mm,ex_um,ey_um,ez_um,ux_um,uy_um,uz_um"
    assert rows[2].split(",") == ["100", "50", "20", *(f"{v:.4f}" for v in e_file[1]),
                                  *(f"{v:.4f}" for v in u_file[1])]
    with pytest.raises(VolcalInputError, match="outside the model's travel 0..600 mm") as err:
        predict_step.predict(res, [[700.0, 0.0, 0.0]])
    assert err.value.file is None
    with pytest.raises(ParameterError, match="points of shape"):
        predict_step.predict(res, [[1.0, 2.0]])


def test_plan_replace_keeps_the_old_session(folder, tmp_path):
    out = tmp_path / "P"
    plan_step.plan(TRAVEL, steps=3, runs=1, output=out)
    with pytest.raises(VolcalInputError, match="--replace"):
        plan_step.plan(TRAVEL, steps=3, runs=1, output=out)  # the refusal's own advice
    p = plan_step.plan(TRAVEL, steps=3, runs=1, tests="linear", output=out, replace=True)
    assert p.backup is not None and (p.backup / "session.toml").is_file()
    assert p.n_backed_up > 0
    assert {m.kind for m in p.session.measurements} == {"linear"}


def test_compensate_names_the_sign_override_and_the_forced_table(identified, folder, tmp_path):
    from volcal.errors import spell
    from volcal.steps.compensate import compensate

    res = identified.result
    r = compensate(res, format="fanuc", output=tmp_path / "f", sign="error")
    assert r.sign == "error" and not r.convention and "FANUC_PITCH.TXT" in r.files
    assert spell(r.sign_note, {}).startswith("sign=error overrides the fanuc convention "
                                             "'correction'")
    assert spell(r.sign_note, OPTIONS).startswith("--sign error overrides the fanuc "
                                                  "convention 'correction'")
    assert r.session is None and r.line_checks == () and r.volumetric_before_um is None
    # an error table of another machine with the session: refused, then forced
    other = tmp_path / "other.csv"
    from volcal.measure.virtual import random_machine
    from volcal.session.errortable import write_error_table

    write_error_table(random_machine(np.array([[0, 500], [0, 400], [0, 300]], float),
                                     "XYFZ", 1), other)
    with pytest.raises(ParameterError) as e:
        compensate(other, format="csv", output=tmp_path / "c", session=folder)
    assert str(e.value).endswith("; give force=True to write them anyway")
    assert str(e.value.spelled(OPTIONS)).endswith("; give --force to write them anyway")
    r = compensate(other, format="csv", output=tmp_path / "c", session=folder, force=True)
    assert len(r.forced) == 1 and "not of this session's machine" in r.forced[0]
    assert r.volumetric_before_um is not None and r.volumetric_after_um is not None
    assert len(r.line_checks) + len(r.not_checked) > 0
