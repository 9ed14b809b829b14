"""Both faces call the same step function with the same keywords and defaults (issue 25).

For each of plan, advise, program, simulate, import, identify, predict and compensate,
the step function of :mod:`volcal.steps` is replaced by a spy; the command (run with only its
required arguments) and the :class:`volcal.Calibration` method (called with only its
required arguments) must reach that one function, and the keywords they pass, completed
with the step signature's defaults, must be the same values: the defaults are defined
once, in the step's signature (from :mod:`volcal.defaults`). A parameter only one face
passes is listed with the reason. Replaces the parity tests of these steps
(test_defaults_parity's SHARED entries plan, simulate, identify, advise, program,
import, compensate; test_plan_travel_and_multilateration_defaults,
test_identify_budget_default_equals_the_cli; test_python_flow's
test_advise_and_program_match_the_cli; test_python_parity_budget's comparisons of
simulate and identify with the CLI).
"""

from __future__ import annotations

import importlib
import inspect
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

from volcal import Calibration
from volcal import defaults as D
from volcal.errors import ParameterError, VolcalInputError

TRAVEL = [[0, 400], [0, 300], [0, 200]]


class Reached(Exception):
    """Raised by the spy: the face reached the step function."""


def _spy(monkeypatch: pytest.MonkeyPatch, module: str, name: str) -> dict[str, Any]:
    mod = importlib.import_module(f"volcal.steps.{module}")
    real = getattr(mod, name)
    calls: dict[str, Any] = {"real": real}

    def fake(*args: Any, **kwargs: Any) -> None:
        bound = inspect.signature(real).bind(*args, **kwargs)  # the step's own keywords
        calls.setdefault("passed", []).append(dict(kwargs))
        bound.apply_defaults()
        calls.setdefault("bound", []).append(dict(bound.arguments))
        raise Reached

    monkeypatch.setattr(mod, name, fake)
    return calls


def _norm(v: Any) -> Any:
    """One spelling of a value: arrays and sequences of numbers as float tuples."""
    if isinstance(v, np.ndarray | list | tuple):
        items = [_norm(x) for x in v]
        if all(isinstance(x, int | float) and not isinstance(x, bool) for x in items):
            return tuple(float(x) for x in items)
        return tuple(items)
    if isinstance(v, dict):
        return {k: _norm(x) for k, x in v.items()}
    if isinstance(v, int | float) and not isinstance(v, bool):
        return float(v)
    return v


def _cli(*args: str) -> None:
    from volcal.cli import app

    r = CliRunner().invoke(app, [str(a) for a in args])
    assert isinstance(r.exception, Reached), (r.output, r.exception)


@pytest.fixture(scope="module")
def planned(tmp_path_factory: pytest.TempPathFactory) -> Calibration:
    cal = Calibration.plan(TRAVEL, steps=3, runs=2, tests=["diagonal", "linear"])
    cal.save(tmp_path_factory.mktemp("p") / "P")
    return cal


# step -> (module, function, CLI-only keywords, Python-only keywords, keywords whose value
# the faces pass differently on purpose)
ONLY = {
    "plan": ({"output": "Calibration.save(folder) writes the session",
              "replace": "Calibration.save refuses to replace measured readings"}, {}),
    "simulate": ({}, {}),
    "program": ({}, {}),
    "advise": ({}, {}),
    "identify": ({}, {}),
    "import": ({}, {}),
    "predict": ({"session": "Calibration.load_model(path, force) checks the binding",
                 "force": "Calibration.load_model(path, force=True)"}, {}),
}


def _compare(calls: dict[str, Any], differ: dict[str, str] | None = None) -> dict[str, Any]:
    """The two faces' keywords, completed with the defaults, are the same values."""
    cli, py = calls["bound"]
    differ = differ or {}
    assert set(cli) == set(py)
    for k in cli:
        if k in differ:
            continue
        if isinstance(cli[k], str | Path) and not isinstance(py[k], bool | int | float):
            continue  # the folder each face was given, or the session read from it
        assert _norm(cli[k]) == _norm(py[k]), (k, cli[k], py[k])
    # the CLI passes every keyword explicitly: its defaults are the step's
    sig = inspect.signature(calls["real"])
    for k, v in calls["passed"][0].items():
        d = sig.parameters[k].default
        if d is inspect.Parameter.empty or k in differ or isinstance(v, Path):
            continue
        assert _norm(v) == _norm(d), f"the CLI's default of {k} is {v!r}, the step's {d!r}"
    return cli


def test_plan(monkeypatch, tmp_path):
    calls = _spy(monkeypatch, "plan", "plan")
    _cli("plan", "--travel", "0:400,0:300,0:200", "-o", tmp_path / "P")
    with pytest.raises(Reached):
        Calibration.plan(TRAVEL)
    from volcal.steps.plan import multilateration_layout

    cli, py = calls["bound"]
    assert cli["output"] == tmp_path / "P" and py["output"] is None  # save() writes
    cli_tests, py_tests = cli.pop("tests"), py.pop("tests")
    assert cli_tests.split(",") == list(py_tests) == list(D.PLAN_TESTS)
    assert cli.pop("step_orders").split(",") == list(py.pop("step_orders"))
    # the CLI's --grid/--stations/--tool-offsets text is the default layout
    assert _norm(multilateration_layout(cli.pop("multilateration"))) == \
        _norm(multilateration_layout(py.pop("multilateration")))
    calls["bound"] = [cli, py]
    calls["passed"][0] = {k: v for k, v in calls["passed"][0].items()
                          if k not in ("tests", "step_orders", "multilateration")}
    _compare(calls, {"output": "save()", "travel": "given"})


def test_plan_add(monkeypatch, planned):
    """plan --add takes the plan's keywords (but travel, chain, name: the session's)."""
    from volcal.steps import plan as step

    add, full = inspect.signature(step.add), inspect.signature(step.plan)
    for k, p in add.parameters.items():
        if k != "folder":
            assert p.default == full.parameters[k].default, k
    calls = _spy(monkeypatch, "plan", "add")
    _cli("plan", "--add", planned.session.path, "--tests", "linear:x")
    assert calls["passed"][0]["tests"] == "linear:x"


def test_advise(monkeypatch, planned):
    calls = _spy(monkeypatch, "advise", "advise")
    _cli("advise", planned.session.path)
    with pytest.raises(Reached):
        planned.advise()
    _compare(calls)


def test_program(monkeypatch, planned, tmp_path):
    calls = _spy(monkeypatch, "program", "program")
    _cli("program", planned.session.path, "--dialect", "fanuc", "-o", tmp_path / "a")
    with pytest.raises(Reached):
        planned.program(tmp_path / "b", "fanuc")
    cli, py = calls["bound"]
    assert callable(cli["on_moved"]) and py["on_moved"] is None  # the CLI says it at once
    _compare(calls, {"on_moved": "above"})


def test_simulate(monkeypatch, planned):
    calls = _spy(monkeypatch, "simulate", "simulate")
    _cli("simulate", planned.session.path)
    with pytest.raises(Reached):
        planned.simulate()
    cli, py = calls["bound"]
    # Python simulates in memory; save() refuses to replace measured readings on disk
    assert cli["overwrite"] is False and py["overwrite"] is True
    _compare(calls, {"overwrite": "in memory"})


def test_import(monkeypatch, tmp_path):
    calls = _spy(monkeypatch, "importer", "import_")
    _cli("import", tmp_path / "x.csv", "--session", tmp_path / "s")
    with pytest.raises(Reached):
        Calibration.import_(tmp_path / "x.csv", session=tmp_path / "s")
    _compare(calls)


def test_identify(monkeypatch, planned, tmp_path):
    calls = _spy(monkeypatch, "identify", "identify")
    _cli("identify", planned.session.path, "-o", tmp_path / "m.json")
    with pytest.raises(Reached):
        planned.identify()
    cli = _compare(calls)
    assert set(calls["passed"][1]) == {"budget"}  # every other default is the step's
    assert cli["monte_carlo"] == D.MONTE_CARLO and cli["max_nodes"] == D.MAX_NODES


def test_identify_defaults_are_the_estimators():
    """The step's defaults are IdentifyOptions' for every field they share."""
    from dataclasses import MISSING, fields

    from volcal.identify import IdentifyOptions
    from volcal.steps.identify import identify

    sig = inspect.signature(identify).parameters
    shared = 0
    for f in fields(IdentifyOptions):
        name = "measurements" if f.name == "measurement_ids" else f.name
        if name == "settings":  # None is IdentifyOptions' EstimatorSettings() (a file or
            assert sig[name].default is None  # an object may be given instead)
            shared += 1
        elif name in sig:
            d = f.default_factory() if f.default is MISSING else f.default
            assert sig[name].default == (d or None if isinstance(d, dict) else d), name
            shared += 1
    assert shared >= 7


def test_predict(monkeypatch, planned, tmp_path):
    calls = _spy(monkeypatch, "predict", "predict")
    _cli("predict", tmp_path / "m.json", "--points", tmp_path / "p.csv", "-o",
         tmp_path / "e.csv")
    planned.result = object()  # the model: the spy never uses it
    try:
        with pytest.raises(Reached):
            planned.predict(tmp_path / "p.csv")
    finally:
        planned.result = None
    cli, py = calls["bound"]
    for k in ONLY["predict"][0]:  # the binding is load_model's in Python
        assert py[k] == inspect.signature(calls["real"]).parameters[k].default
    assert cli["model"] == tmp_path / "m.json"
    _compare(calls, {"model": "a file or the calibration's model"})


def test_compensate(monkeypatch, planned, tmp_path):
    calls = _spy(monkeypatch, "compensate", "compensate")
    _cli("compensate", tmp_path / "m.json", "--format", "fanuc", "-o", tmp_path / "a")
    planned.result = object()  # the model: the spy never uses it
    try:
        with pytest.raises(Reached):
            planned.compensate(tmp_path / "b", format="fanuc")
    finally:
        planned.result = None
    cli, py = calls["bound"]
    assert cli["machine"] is None  # the CLI's: the session's, else the model file's
    assert py["machine"] is not None and py["machine"].name == planned.session.name
    assert cli["sign"] is None is py["sign"]  # never a fixed sign: the controller's own
    assert callable(cli["on_moved"]) and py["on_moved"] is None  # the CLI says it at once
    _compare(calls, {"model": "a file or the calibration's model", "machine": "above",
                     "on_moved": "above"})


@pytest.mark.parametrize("method,module,name", [
    ("plan", "plan", "plan"), ("advise", "advise", "advise"),
    ("program", "program", "program"), ("simulate", "simulate", "simulate"),
    ("import_", "importer", "import_"), ("identify", "identify", "identify"),
    ("predict", "predict", "predict"), ("compensate", "compensate", "compensate")])
def test_python_signature_is_the_steps(method, module, name):
    """Calibration's keywords have the step's names and defaults (``folder`` is
    ``output``; ``**options`` forwards the rest)."""
    step = inspect.signature(getattr(importlib.import_module(f"volcal.steps.{module}"), name))
    face = inspect.signature(getattr(Calibration, method))
    rename = {"folder": "output"}
    for k, p in face.parameters.items():
        if k in ("self", "cls") or p.kind is p.VAR_KEYWORD:
            continue
        s = step.parameters[rename.get(k, k)]  # every Python keyword is a step keyword
        if p.default is not p.empty and s.default is not s.empty:
            assert _norm(p.default) == _norm(s.default), (method, k)


@pytest.mark.parametrize("template,python,cli", [
    ("{noise_um=}-1.0: expected a positive repeatability [um]",
     "noise_um=-1.0: expected a positive repeatability [um]",
     "--noise-um -1.0: expected a positive repeatability [um]"),
    ("{known_u} needs {known} (the error table it applies to)",
     "known_u needs known (the error table it applies to)",
     "--known-u needs --known (the error table it applies to)"),
    ("a {mirror_misalignment_urad=}3", "a mirror_misalignment_urad=3", "a --mirror-urad 3"),
])
def test_a_parameter_is_named_as_each_face_names_it(template, python, cli):
    from volcal.cli._options import OPTIONS

    e = ParameterError(template, "f.toml")
    assert isinstance(e, VolcalInputError) and e.message == python
    assert str(e) == f"f.toml: {python}"
    assert str(e.spelled(OPTIONS)) == f"f.toml: {cli}"
    assert str(e.spelled({}, "Calibration.x: ")) == f"f.toml: Calibration.x: {python}"


def test_every_parameter_the_steps_name_has_an_option():
    """Each keyword of a step that the CLI passes is in the table (or typer's spelling)."""
    from volcal.cli._options import OPTIONS

    for module, name in [("plan", "plan"), ("advise", "advise"), ("program", "program"),
                         ("simulate", "simulate"), ("importer", "import_"),
                         ("identify", "identify"), ("predict", "predict"),
                         ("compensate", "compensate")]:
        sig = inspect.signature(getattr(importlib.import_module(f"volcal.steps.{module}"),
                                        name))
        for k, p in sig.parameters.items():
            if p.kind is p.KEYWORD_ONLY and k != "on_moved":  # a callback of the CLI's
                assert k in OPTIONS, (name, k)
