"""Issue 25, findings 6 and 7: damaged model files, non-finite values, the model binding.

A missing or truncated ``MODEL.npz`` is named in every command that loads the model (no
traceback, exit code 2 where the uncertainty is needed; a warning where only the
functions are); a model holding NaN, infinity or 1e12 um is refused on load with the file
and the key; no controller table and no prediction is ever written with a value that is
not a number.
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json
import shutil
import warnings
import zipfile

import numpy as np
import pytest

from volcal.compensate.formats import FORMAT_INFO, CompensationOptions, write_compensation
from volcal.errors import VolcalInputError
from volcal.identify import identify, load_model
from volcal.identify.modelfile import ModelFileWarning, check_model_session
from volcal.identify.record import readings_sha256
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.plan.planner import plan_session
from volcal.session.format import read_session, write_session
from volcal_cli_helpers import run_volcal

TRAVEL = np.array([[0.0, 300.0], [0.0, 200.0], [0.0, 100.0]])
FORMATS = list(FORMAT_INFO)


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """A small simulated session and its model on disk (read-only for the tests)."""
    from conftest import machine

    root = tmp_path_factory.mktemp("damaged")
    s = plan_session(TRAVEL, "XYFZ", 4, ("step-diagonal", "diagonal", "linear"), runs=2,
                     name="MILL-D")
    simulate_session(s, machine("XYFZ", 3, travel=TRAVEL, n_nodes=9),
                     SimulationOptions(noise_um=0.3, seed=4))
    write_session(s, root / "S")
    identify(read_session(root / "S")).to_json(root / "model.json")
    (root / "points.csv").write_text("x_mm,y_mm,z_mm\n100,50,20\n")
    return root


@pytest.fixture
def copy(small, tmp_path):
    """The model and its binary part copied beside each other into ``tmp_path``."""
    for name in ("model.json", "model.npz"):
        shutil.copy(small / name, tmp_path / name)
    return tmp_path / "model.json", tmp_path / "model.npz"


def _damage(npz, how: str) -> str:
    """Remove or truncate the binary part; the reason the message must give."""
    size = npz.stat().st_size
    if how == "missing":
        npz.unlink()
        return (f"its binary part {npz} is missing (copy it beside model.json, or identify "
                "again)")
    npz.write_bytes(npz.read_bytes()[:1000])
    return (f"its binary part {npz} is truncated or damaged (1000 bytes, the JSON records "
            f"{size}: copy it again beside model.json, or identify again)")


@pytest.mark.parametrize("how", ["missing", "truncated"])
def test_a_missing_or_truncated_npz_is_named_by_every_command(how, small, copy, tmp_path,
                                                              monkeypatch, capsys):
    model, npz = copy
    why = _damage(npz, how)
    s = str(small / "S")
    needs_u = {
        "evaluate": ["evaluate", "session", s, "--model", str(model)],
        "predict": ["predict", str(model), "--points", str(small / "points.csv"), "-o",
                    str(tmp_path / "p.csv")],
        "report": ["report", s, "--model", str(model), "-o", str(tmp_path / "R")],
        "history": ["history", "add", s, "--model", str(model), "--db",
                    str(tmp_path / "h.sqlite"), "--create"],
    }
    for name, args in needs_u.items():
        code, out, err = run_volcal(monkeypatch, capsys, *args)
        assert code == 2, (name, out, err)
        assert "Traceback" not in err and "IndexError" not in err
        # the error names the binary part as its file, then why
        assert f"error: {npz}: " in err and err.rstrip().endswith(why), (name, err)
    assert not (tmp_path / "p.csv").exists() and not (tmp_path / "R").exists()
    for fmt in FORMATS:  # the tables need only the functions: written, with the warning
        with warnings.catch_warnings():
            warnings.simplefilter("always")  # as in a new process: every run warns
            code, out, err = run_volcal(monkeypatch, capsys, "compensate", str(model),
                                        "--format", fmt, "-o", str(tmp_path / fmt))
        assert code == 0, err
        assert f"warning: {model}: loaded without uncertainty: {why}" in err
        assert "warning" not in out
    # Python: the warning on load, the refusal (naming the npz) where the U is needed
    from volcal.flow import Calibration

    cal = Calibration.open(small / "S")
    with pytest.warns(ModelFileWarning, match="loaded without uncertainty"):
        cal.load_model(model)
    with pytest.raises(VolcalInputError) as exc:
        cal.evaluate()
    assert exc.value.file == str(npz) and str(exc.value).endswith(why)


def _write(model, doc) -> None:
    model.write_text(json.dumps(doc))  # json writes NaN and Infinity as JS literals


@pytest.mark.parametrize(("value", "said"), [
    (float("nan"), "not a finite number"),
    (float("inf"), "not a finite number"),
    (1e12, "1e+12 um is not a plausible error (at most 10000 um; see docs/formats.md, "
     "'Model file')"),
])
def test_a_non_finite_or_implausible_model_is_refused(value, said, small, copy, tmp_path,
                                                      monkeypatch, capsys):
    model, _ = copy
    doc = json.loads(model.read_text())
    doc["functions"]["X"]["EXX_um"][2] = value
    _write(model, doc)
    msg = (f"error: {model}, column 'functions.X.EXX_um[2]': {said}: the model file is "
           "damaged (identify again)")
    runs = [["compensate", str(model), "--format", fmt, "-o", str(tmp_path / fmt)]
            for fmt in FORMATS]
    runs += [["predict", str(model), "--points", str(small / "points.csv"), "-o", "-"],
             ["evaluate", "session", str(small / "S"), "--model", str(model)]]
    for args in runs:
        code, out, err = run_volcal(monkeypatch, capsys, *args)
        assert code == 2 and err.strip().splitlines()[-1] == msg, (args, err)
        assert "nan" not in out.lower() and "inf" not in out.lower()
    assert not any((tmp_path / fmt).exists() for fmt in FORMATS)


@pytest.mark.parametrize(("key", "value", "said"), [
    (("functions", "Y", "u_EAY_urad", 1), -2.0, "-2 urad is negative"),
    (("squareness_urad", "EB0Z"), 2e4, "20000 urad is not a plausible error"),
    (("functions", "Z", "position_mm", 0), float("nan"), "not a finite number"),
])
def test_load_model_names_the_key(key, value, said, copy):
    model, _ = copy
    doc = json.loads(model.read_text())
    d = doc
    for k in key[:-1]:
        d = d[k]
    d[key[-1]] = value
    _write(model, doc)
    with pytest.raises(VolcalInputError) as exc:
        load_model(model)
    name = ".".join(str(k) for k in key[:-1]) + (f"[{key[-1]}]" if isinstance(key[-1], int)
                                                 else f".{key[-1]}")
    assert exc.value.file == str(model) and exc.value.column == name
    assert exc.value.message.startswith(said)


def test_a_nan_in_the_binary_part_is_refused_even_with_its_digest(copy):
    """A binary part whose digest matches but which holds NaN: refused, the member named."""
    model, npz = copy
    with np.load(npz) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["noise_factor"][3, 0] = np.nan
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_STORED) as zf:
        for k, a in arrays.items():
            member = io.BytesIO()
            np.lib.format.write_array(member, a, allow_pickle=False)
            zf.writestr(f"{k}.npy", member.getvalue())
    npz.write_bytes(buf.getvalue())
    doc = json.loads(model.read_text())
    doc["arrays"]["sha256"] = hashlib.sha256(buf.getvalue()).hexdigest()
    doc["arrays"]["bytes"] = len(buf.getvalue())
    _write(model, doc)
    with pytest.raises(VolcalInputError) as exc:
        load_model(model)
    assert exc.value.file == str(npz) and exc.value.column == "noise_factor"
    assert "not a finite number" in exc.value.message


@pytest.mark.parametrize("fmt", FORMATS)
def test_no_table_is_written_from_a_nan(fmt, small, tmp_path):
    """The writers' last guard: a MachineErrors holding NaN gives no file, in every format."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        errors = load_model(small / "model.json").errors
    errors.values[0][3, 0] = np.nan  # EXX at the fourth node of X
    with pytest.raises(VolcalInputError, match="not a finite number at") as exc:
        write_compensation(errors, fmt, tmp_path / "C", CompensationOptions(spacing=25.0))
    assert "no table is written" in str(exc.value)
    assert not (tmp_path / "C").exists()


def test_no_prediction_is_made_from_a_nan(small):
    r = load_model(small / "model.json")
    r.errors.values[1][:, 1] = np.nan  # EYY
    with pytest.raises(VolcalInputError, match=r"not a finite number at \(100, 50, 20\) mm"):
        r.predict([[100.0, 50.0, 20.0]])


def test_a_reading_that_is_no_number_is_named_without_numpy_repr():
    from volcal.standards.iso230_2 import evaluate

    with pytest.raises(VolcalInputError) as exc:
        evaluate([0, 100, 0, 100], [1, 1, 1, 1], ["+", "+", "-", "-"],
                 [0.0, np.nan, 0.0, 1.0], file="l.csv", rows=[2, 3, 4, 5])
    assert str(exc.value) == "l.csv, row 3, column 'deviation_um': not a finite number: nan"


def test_models_of_older_versions_still_bind(small):
    """The readings' hash counts the measured readings; the old numbering still binds."""
    s = read_session(small / "S")
    assert readings_sha256(s) == readings_sha256(s, legacy=True)  # no NaN: one hash
    m = s.measurements[0]
    m.deviation = m.deviation.copy()
    m.deviation[2] = np.nan  # a reading a Python caller left unmeasured
    new, old = readings_sha256(s)[0], readings_sha256(s, legacy=True)[0]
    assert new != old
    model = load_model(small / "model.json")
    for digest in (new, old):  # the hash this version writes, and the one older ones did
        model.session = dataclasses.replace(model.session, readings_sha256=digest)
        assert check_model_session(model, s) == []
    model.session = dataclasses.replace(model.session, readings_sha256="0" * 64)
    with pytest.raises(VolcalInputError, match="the model does not belong to this session"):
        check_model_session(model, s)
