"""The estimator's settings from a file (``volcal identify --estimator-settings``).

The command line reaches every field of :class:`volcal.identify.EstimatorSettings` through
a TOML file, as Python does with ``settings=``: the same numbers from both faces, the
changed fields recorded in the model file (``fit.estimator_settings``) and read back, and a
file with a mistake refused naming the file, the line and the key, nothing written.

One small virtual machine (500 x 400 x 300 mm, steps 3, 2 runs, diagonals and linear tests)
is simulated once; the CLI runs in-process.
"""

from __future__ import annotations

import json
import re
import sys
import tomllib
from dataclasses import fields
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from volcal import Calibration
from volcal.errors import VolcalInputError
from volcal.identify import EstimatorSettings
from volcal.identify.settings_file import (
    changed_settings,
    read_estimator_settings,
    settings_from_mapping,
)

TRAVEL = [[0, 500], [0, 400], [0, 300]]


def _run(monkeypatch, capsys, *args: str) -> SimpleNamespace:
    """``volcal ARGS`` in-process."""
    from volcal.cli import main

    monkeypatch.setattr(sys, "argv", ["volcal", *args])
    code = 0
    try:
        main()
    except SystemExit as exc:
        code = exc.code or 0
    out = capsys.readouterr()
    return SimpleNamespace(code=code, out=out.out, err=out.err)


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    """A simulated session folder."""
    root = tmp_path_factory.mktemp("est")
    Calibration.plan(TRAVEL, steps=3, runs=2, tests=["diagonal", "linear"],
                     name="EST-500").save(root / "s")
    Calibration.open(root / "s").simulate(seed=11).save(root / "s")
    return root / "s"


@pytest.fixture(scope="module")
def default_fit(session):
    """The fit with volcal's settings (Python)."""
    return Calibration.open(session).identify()


def test_file_reaches_the_estimator_like_python(session, default_fit, tmp_path, monkeypatch,
                                                capsys):
    """``--estimator-settings`` with ``between_readings_factor = 0`` gives Python's numbers
    with ``settings=EstimatorSettings(between_readings_factor=0)``: the estimate unchanged,
    the uncertainty at the node values no reading touches without the part between the
    readings (smaller than the default's there, equal elsewhere)."""
    f = tmp_path / "est.toml"
    f.write_text("# smooth guideways\nbetween_readings_factor = 0.0\n", "utf-8")
    r = _run(monkeypatch, capsys, "identify", str(session), "-o", str(tmp_path / "m.json"),
             "--estimator-settings", str(f))
    assert r.code == 0, r.err
    model = json.loads((tmp_path / "m.json").read_text("utf-8"))
    assert model["fit"]["estimator_settings"] == {"between_readings_factor": 0.0}
    py = Calibration.open(session).identify(
        settings=EstimatorSettings(between_readings_factor=0.0))
    cli = Calibration.open(session).load_model(tmp_path / "m.json")
    assert cli.between_factor is None or cli.between_factor.shape[1] == 0
    untouched = default_fit.between_factor.shape[1]
    assert untouched > 0  # the design leaves node values between the readings
    for k in range(3):  # the model file's values are written to 7 significant digits
        np.testing.assert_allclose(cli.errors.values[k], py.errors.values[k], rtol=1e-6,
                                   atol=1e-6)
        np.testing.assert_array_equal(py.errors.values[k], default_fit.errors.values[k])
        np.testing.assert_allclose(cli.std[k], py.std[k], rtol=1e-6, atol=1e-6)
    grow = np.concatenate([(default_fit.std[k] - py.std[k]).ravel() for k in range(3)])
    assert grow.min() > -1e-9  # the default's part only adds
    assert np.sum(grow > 1e-6) >= untouched // 6  # and is there at untouched nodes
    assert "estimator_settings" not in default_fit.fit.extra


def test_python_takes_the_file_too(session, tmp_path):
    """``Calibration.identify(settings=FILE)`` = ``settings=EstimatorSettings(...)``, tuples
    and the ``[estimator]`` table included."""
    f = tmp_path / "est.toml"
    f.write_text("[estimator]\nroll_factor = 2\ngroup_kappa = [1, 1, 1, 1]\n"
                 "travel_exponent_groups = [[0, 1, 2, 3]]\n"
                 "travel_exponent_bounds = [-1, 2]\n", "utf-8")
    want = EstimatorSettings(roll_factor=2.0, group_kappa=(1.0, 1.0, 1.0, 1.0),
                             travel_exponent_groups=((0, 1, 2, 3),),
                             travel_exponent_bounds=(-1.0, 2.0))
    assert read_estimator_settings(f) == want
    a = Calibration.open(session).identify(settings=f)
    b = Calibration.open(session).identify(settings=want)
    for k in range(3):
        np.testing.assert_array_equal(a.errors.values[k], b.errors.values[k])
    assert a.fit["estimator_settings"] == changed_settings(want)
    assert settings_from_mapping(a.fit["estimator_settings"]) == want  # read back


def test_changed_settings_round_trip():
    """Every field's changed value is written and read back exactly (JSON values)."""
    s = EstimatorSettings(typical_scales=(1.0, 2.0, 3.0, 4.0), nugget=False,
                          roll_mixture_covariance="mixture", hyper_max_nodes=31,
                          travel_exponent_bounds=((-0.5, 1.5), (0.0, 1.0)),
                          between_readings_factor=3.0)
    d = changed_settings(s)
    assert set(d) == {"typical_scales", "nugget", "roll_mixture_covariance",
                      "hyper_max_nodes", "travel_exponent_bounds", "between_readings_factor"}
    assert settings_from_mapping(json.loads(json.dumps(d))) == s
    assert changed_settings(EstimatorSettings()) == {}


@pytest.mark.parametrize("text, row, key, words", [
    ("# x\nbetwen_readings_factor = 0\n", 2, "betwen_readings_factor",
     "did you mean between_readings_factor"),
    ("roll_factor = 'big'\n", 1, "roll_factor", "expected a number"),
    ("nugget = 1\n", 1, "nugget", "expected true or false"),
    ("hyper_max_nodes = 21.5\n", 1, "hyper_max_nodes", "expected a whole number"),
    ("typical_scales = [10, 5]\n", 1, "typical_scales", "expected 4 numbers"),
    ("\n\nroll_mixture_absent = 1.5\n", 3, "roll_mixture_absent", "must be in [0, 1)"),
    ("[estimator]\nroll_factor = 1\n[solver]\nx = 1\n", 3, "solver", "unknown table"),
    ("roll_factor = 1\n[estimator]\nroll_factor = 2\n", 1, "roll_factor", "given twice"),
    ("between_readings_factor = -1.0\n", 1, "between_readings_factor",
     "must be 0 (off) or a positive number"),
    ("# grids\nhyper_max_nodes = 2\n", 2, "hyper_max_nodes", "a whole number >= 3"),
])
def test_mistakes_name_file_line_and_key(session, tmp_path, monkeypatch, capsys, text, row,
                                         key, words):
    """A mistake in the file: exit 2, the file, line and key named, no model written."""
    f = tmp_path / "est.toml"
    f.write_text(text, "utf-8")
    with pytest.raises(VolcalInputError) as e:
        read_estimator_settings(f)
    assert (e.value.file, e.value.row, e.value.column) == (str(f), row, key)
    assert words in e.value.message
    out = tmp_path / "m.json"
    r = _run(monkeypatch, capsys, "identify", str(session), "-o", str(out),
             "--estimator-settings", str(f))
    assert r.code == 2
    assert f"{f}, row {row}, column '{key}'" in r.err and words in r.err
    assert "Traceback" not in r.err
    assert not out.exists() and not out.with_suffix(".npz").exists()


def test_missing_or_invalid_file(session, tmp_path, monkeypatch, capsys):
    """No file, or not TOML: exit 2 naming the file."""
    bad = tmp_path / "bad.toml"
    bad.write_text("roll_factor = = 2\n", "utf-8")
    for f, words in ((tmp_path / "none.toml", "no such estimator settings file"),
                     (bad, "invalid TOML")):
        r = _run(monkeypatch, capsys, "identify", str(session), "-o",
                 str(tmp_path / "m.json"), "--estimator-settings", str(f))
        assert r.code == 2 and str(f) in r.err and words in r.err, r.err


def test_report_names_the_changed_settings(session, default_fit):
    """The report's uncertainty section names the settings that differ and states the
    factor between the readings it used (three times, not the default's twice)."""
    from volcal.report.uncertainty import uncertainty_section

    three = Calibration.open(session).identify(
        settings=EstimatorSettings(between_readings_factor=3.0))
    text = {}
    for key, r in (("default", default_fit), ("three", three)):
        sec = uncertainty_section(SimpleNamespace(result=r, volumetric=None))
        text[key] = " ".join(sec.paragraphs)
    assert "twice the fitted smoothness prior" in text["default"]
    assert "differ from volcal's defaults" not in text["default"]
    assert "3 times the fitted smoothness prior" in text["three"]
    assert ("The estimator's settings differ from volcal's defaults (volcal identify "
            "--estimator-settings; recorded in the model file as fit.estimator_settings): "
            "between_readings_factor = 3.0.") in text["three"]
    b3 = np.concatenate([three.std[k].ravel() for k in range(3)])
    b2 = np.concatenate([default_fit.std[k].ravel() for k in range(3)])
    assert np.all(b3 >= b2 - 1e-12) and np.any(b3 > b2 + 1e-6)


def test_advise_takes_the_file(session, tmp_path, monkeypatch, capsys):
    """``volcal advise --estimator-settings`` = ``Calibration.advise(settings=FILE)``: the
    typical scales doubled (the squareness prior kept) nearly double the design's volumetric
    ambiguity (measured 5.36 -> 9.98 um)."""
    f = tmp_path / "est.toml"
    f.write_text("typical_scales = [20.0, 10.0, 30.0, 30.0]\n", "utf-8")
    amb = {}
    for key, extra in (("default", ()), ("file", ("--estimator-settings", str(f)))):
        r = _run(monkeypatch, capsys, "advise", str(session), "--json", *extra)
        assert r.code == 0, r.err
        amb[key] = json.loads(r.out)["identifiability"]["ambiguity_um"]
    py = Calibration.open(session).advise(settings=f)
    assert py.ambiguity_um == pytest.approx(amb["file"], rel=1e-12)
    assert 1.5 < amb["file"] / amb["default"] <= 2.0


def test_the_template_lists_every_field_with_its_default():
    """docs/estimator-settings.toml: every field once, commented out with its default; as
    it is and with every field uncommented it reads as volcal's defaults."""
    path = Path(__file__).resolve().parents[2] / "docs" / "estimator-settings.toml"
    text = path.read_text("utf-8")
    lines = [ln for ln in text.splitlines() if re.match(r"^# \w+ = ", ln)]
    names = [ln[2:].split(" = ")[0] for ln in lines]
    assert names == [f.name for f in fields(EstimatorSettings)]
    assert read_estimator_settings(path) == EstimatorSettings()
    uncommented = "\n".join(ln[2:] if ln in lines else ln for ln in text.splitlines())
    doc = tomllib.loads(uncommented)
    assert set(doc["estimator"]) == set(names)
    assert settings_from_mapping(doc, path, uncommented) == EstimatorSettings()
