"""The Python API's defaults are the command line's (issue 20, item 1).

The CLI's defaults are read by introspection of the typer command callbacks (the
``typer.Option`` defaults and the ``Annotated`` signature defaults) and compared with the
signatures of :class:`volcal.Calibration` and of the library functions and option classes
they call, for every shared parameter. A parameter only one side has is listed below with
the reason; a new CLI option that Python does not take fails this test until it is added
or listed.

The steps plan, advise, program, simulate, import, identify, predict and compensate are
one function each (``volcal.steps``) behind both faces: tests/test_steps_signature.py
checks them (it replaced their entries here).
"""

from __future__ import annotations

import dataclasses
import inspect
import re
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from typer.models import OptionInfo, ParameterInfo

from volcal import Calibration
from volcal import defaults as D

REQUIRED = "<required>"


def _cli_callback(path: str) -> Callable[..., Any]:
    from volcal.cli import full_app

    app = full_app()  # volcal.cli.app registers its commands lazily

    parts = path.split()
    if len(parts) == 1:
        for c in app.registered_commands:
            if (c.name or c.callback.__name__) == parts[0]:
                return c.callback
    else:
        for g in app.registered_groups:
            if g.name == parts[0]:
                for c in g.typer_instance.registered_commands:
                    if c.name == parts[1]:
                        return c.callback
    raise AssertionError(f"no CLI command {path!r}")


def cli_defaults(path: str) -> dict[str, Any]:
    """Parameter name -> default of a typer command (REQUIRED when it has none)."""
    out = {}
    for name, p in inspect.signature(_cli_callback(path)).parameters.items():
        d = p.default
        if isinstance(d, ParameterInfo):  # old style: = typer.Option(default, ...)
            d = d.default
        out[name] = REQUIRED if d is inspect.Parameter.empty or d is ... else d
    return out


def py_defaults(func: Callable[..., Any]) -> dict[str, Any]:
    """Parameter name -> default of a Python callable or dataclass."""
    if dataclasses.is_dataclass(func):
        out = {}
        for f in dataclasses.fields(func):
            if f.default is not dataclasses.MISSING:
                out[f.name] = f.default
            elif f.default_factory is not dataclasses.MISSING:
                out[f.name] = f.default_factory()
            else:
                out[f.name] = REQUIRED
        return out
    return {n: REQUIRED if p.default is p.empty else p.default
            for n, p in inspect.signature(func).parameters.items()
            if p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL) and n not in ("self", "cls")}


_NUM = r"[-+]?\d+(\.\d*)?"


def norm(v: Any) -> Any:
    """One spelling of a default: the CLI's text 'x,y,z' equals (x, y, z); {} equals None."""
    if isinstance(v, str) and re.fullmatch(rf"{_NUM}(,{_NUM})+", v):
        return tuple(float(s) for s in v.split(","))
    if isinstance(v, str) and "," in v:
        return tuple(s.strip() for s in v.split(","))
    if isinstance(v, list | tuple | np.ndarray):
        items = [norm(x) for x in v]
        if all(isinstance(x, int | float) and not isinstance(x, bool) for x in items):
            return tuple(float(x) for x in items)
        return tuple(items) if len(items) != 1 else items[0]
    if isinstance(v, dict) and not v:
        return None
    if isinstance(v, int | float) and not isinstance(v, bool):
        return float(v)
    return v


def _evaluate_session():
    from volcal.standards.session import evaluate_session

    return evaluate_session


# CLI command -> [(Python callable, {cli name: python name}), ...], CLI-only parameters.
# A CLI parameter absent from a library function's signature is simply not compared
# with it; it must be in the first callable (the Calibration method) unless listed.
SHARED: dict[str, tuple[list[tuple[Callable[[], Any], dict[str, str | None]]],
                        dict[str, str]]] = {
    "report": (
        [(lambda: Calibration.report, {"output": "folder"})],
        {"session": "the Calibration's session", "model": "Calibration.load_model(path)"}),
    "evaluate session": (
        [(lambda: Calibration.evaluate, {}), (_evaluate_session, {})],
        {"session": "the Calibration's session", "as_json": "SessionEvaluation.to_dict()",
         "tolerance_um": "Calibration.verdict(tolerance_um, compensation), compared below",
         "model": "Calibration.load_model(path)",
         "compensation": "Calibration.verdict(tolerance_um, compensation), below",
         "force": "Calibration.verdict(..., force=True) and Calibration.load_model(path, "
                  "force=True)",
         "decision_rule": "Calibration.verdict(tolerance_um, decision_rule=...): a rule "
                          "judges a tolerance, compared below",
         "guard_band_um": "Calibration.verdict(tolerance_um, guard_band_um=...), below",
         "units": "a display option: SessionEvaluation.rotary[id].to_dict(units)"}),
}


@pytest.mark.parametrize("command", sorted(SHARED))
def test_python_defaults_equal_the_cli(command):
    cli = cli_defaults(command)
    targets, cli_only = SHARED[command]
    compared = 0
    for i, (get, rename) in enumerate(targets):
        py = py_defaults(get())
        for name, d in cli.items():
            if name in cli_only:
                continue
            pname = rename.get(name, name)
            if pname is None:  # same meaning, other spelling (commented in SHARED)
                continue
            if pname not in py:
                assert i > 0, f"volcal {command} --{name}: not taken by the Python API"
                continue
            assert norm(py[pname]) == norm(d), (
                f"volcal {command} --{name} defaults to {d!r} but {get()!r} {pname} to "
                f"{py[pname]!r}")
            compared += 1
    assert compared >= 1
    for name in cli_only:  # listed ones exist (no stale list)
        assert name in cli, f"{command}: {name} is listed but no CLI parameter"


def test_verdict_defaults_equal_evaluate_session():
    cli = cli_defaults("evaluate session")
    py = py_defaults(Calibration.verdict)
    assert py["tolerance_um"] == REQUIRED  # a verdict needs a tolerance
    assert cli["compensation"] is None is py["compensation"]
    assert norm(cli["edition"]) == norm(py["edition"])
    assert cli["force"] is False is py["force"]
    assert cli["decision_rule"] == py["decision_rule"] == D.DECISION_RULE == "simple"
    assert cli["guard_band_um"] is None is py["guard_band_um"]
    assert cli["budget"] is None is py["budget"]
    # the other commands that judge a tolerance take the same rule by default
    assert cli_defaults("report")["decision_rule"] == D.DECISION_RULE
    assert cli_defaults("evaluate iso230-2")["decision_rule"] == D.DECISION_RULE


def test_compensation_defaults_are_safe():
    """No fixed sign (each controller's own), 20 mm, the format always named."""
    comp = py_defaults(Calibration.compensate)
    assert comp["format"] == REQUIRED and cli_defaults("compensate")["format"] == REQUIRED
    assert comp["sign"] is None and D.COMP_SIGN is None
    assert comp["spacing"] == 20.0 == cli_defaults("compensate")["spacing"]


def test_no_any_in_the_public_signatures_of_the_flow():
    import typing

    import volcal.flow as flow

    for name, member in inspect.getmembers(Calibration):
        if name.startswith("_") or not callable(member):
            continue
        func = inspect.unwrap(member)
        typing.get_type_hints(func, vars(flow) | _typing_names())  # every name resolves
        ann = func.__annotations__
        for k, h in ann.items():
            assert not re.search(r"\b(Any|object)\b", str(h)) or k == "options", (
                f"Calibration.{name} {k}: {h}")
        assert "return" in ann, f"Calibration.{name} has no return type"


def _typing_names() -> dict[str, Any]:
    from volcal.identify.identifiability import IdentifiabilityReport
    from volcal.identify.result import IdentificationResult
    from volcal.importer.laser_csv import ImportResult
    from volcal.model.errorfunctions import MachineErrors
    from volcal.report.verdict import Verdict
    from volcal.report.writer import ReportFiles
    from volcal.session.format import Session
    from volcal.standards.session import SessionEvaluation
    from volcal.steps.locate import Located
    from volcal.steps.predict import Prediction
    from volcal.uncertainty.budget import Budget

    return {"Located": Located, "Budget": Budget, "IdentifiabilityReport": IdentifiabilityReport,
            "IdentificationResult": IdentificationResult, "ImportResult": ImportResult,
            "MachineErrors": MachineErrors, "Prediction": Prediction,
            "ReportFiles": ReportFiles, "Session": Session,
            "SessionEvaluation": SessionEvaluation, "Verdict": Verdict}


def test_option_info_is_what_typer_gives():
    """Guard of the introspection itself: an old-style option is an OptionInfo."""
    sig = inspect.signature(_cli_callback("simulate"))
    assert isinstance(sig.parameters["noise_um"].default, OptionInfo)
    assert cli_defaults("simulate")["noise_um"] == D.SIM_NOISE_UM == 0.5
    assert cli_defaults("compensate")["spacing"] == 20.0
