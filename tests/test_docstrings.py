"""Documentation gate: every public callable documents every parameter.

Modelled on python-control's ``control/tests/docstrings_test.py``: the build fails when a public
function or a public method of a public class lacks a numpydoc ``Parameters`` entry for one of its
arguments. ``volcal.cli`` modules only need a docstring (typer builds the help from option texts).
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
import sys
import types
from collections.abc import Callable, Iterator

import pytest

import volcal

_SECTION = re.compile(r"^(?P<title>[A-Z][A-Za-z ]+)\n-{3,}\s*$", re.M)
_ENTRY = re.compile(r"^\*{0,2}(?P<names>\w+(?:\s*,\s*\*{0,2}\w+)*)\s*(?::.*)?$")
_SKIP_KINDS = (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)


def _modules() -> list[str]:
    return sorted(m.name for m in pkgutil.walk_packages(volcal.__path__, "volcal."))


def _is_cli(name: str) -> bool:
    return name == "volcal.cli" or name.startswith("volcal.cli.")


def documented_parameters(doc: str) -> set[str]:
    """Names listed in the ``Parameters`` section of a numpydoc docstring."""
    headers = list(_SECTION.finditer(doc))
    names: set[str] = set()
    for i, header in enumerate(headers):
        if header.group("title").strip() not in ("Parameters", "Other Parameters"):
            continue
        end = headers[i + 1].start() if i + 1 < len(headers) else len(doc)
        for line in doc[header.end() : end].splitlines():
            if not line or line[0].isspace():
                continue  # descriptions are indented below their entry
            match = _ENTRY.match(line.rstrip())
            if match:
                names |= {n.strip().lstrip("*") for n in match.group("names").split(",")}
    return names


def required_parameters(func: Callable) -> list[str]:
    """Arguments of ``func`` that must be documented (no self/cls/*args/**kwargs)."""
    try:
        params = inspect.signature(func).parameters.values()
    except (TypeError, ValueError):
        return []
    return [p.name for p in params if p.name not in ("self", "cls") and p.kind not in _SKIP_KINDS]


def _public_callables(module) -> Iterator[tuple[str, Callable]]:
    """Public functions, public classes and public methods defined in ``module``."""
    for name, obj in sorted(vars(module).items()):
        if name.startswith("_") or getattr(obj, "__module__", None) != module.__name__:
            continue
        if inspect.isfunction(obj):
            yield f"{module.__name__}.{name}", obj
        elif inspect.isclass(obj):
            yield f"{module.__name__}.{name}", obj
            for attr, member in sorted(vars(obj).items()):
                if attr.startswith("_"):
                    continue
                if isinstance(member, staticmethod | classmethod):
                    member = member.__func__
                if inspect.isfunction(member) and member.__qualname__.startswith(obj.__qualname__):
                    yield f"{module.__name__}.{name}.{attr}", member


def _undocumented(module_name: str) -> list[str]:
    module = importlib.import_module(module_name)
    problems = []
    for qualname, obj in _public_callables(module):
        doc = inspect.getdoc(obj) or ""
        if inspect.isclass(obj):
            if _is_cli(module_name) and not doc.strip():
                problems.append(f"{qualname}: no docstring")
            continue
        if not doc.strip():
            problems.append(f"{qualname}: no docstring")
            continue
        if _is_cli(module_name):
            continue
        missing = [p for p in required_parameters(obj) if p not in documented_parameters(doc)]
        if missing:
            problems.append(f"{qualname}: undocumented parameters {', '.join(missing)}")
    return problems


def test_parser_reads_numpydoc_entries():
    doc = inspect.cleandoc(
        """Summary.

        Parameters
        ----------
        a, b : float
            Two numbers [mm].
        c
            Untyped entry.
        *args : tuple
            Extra.

        Returns
        -------
        d : float
            Not a parameter.
        """
    )
    assert documented_parameters(doc) == {"a", "b", "c", "args"}


def test_gate_reports_a_missing_parameter():
    def sample(x: float, y: float, *rest, flag: bool = False, **kw) -> float:
        """Sum.

        Parameters
        ----------
        x : float
            First [mm].
        """
        return x + y

    assert required_parameters(sample) == ["x", "y", "flag"]
    doc = inspect.getdoc(sample) or ""
    assert [p for p in required_parameters(sample) if p not in documented_parameters(doc)] == [
        "y",
        "flag",
    ]


_FAKE_SOURCE = '''
def documented(a, b, *args, **kwargs):
    """Fine.

    Parameters
    ----------
    a, b : float
        Lengths [mm].
    """


def half(x, y=1.0):
    """Only x.

    Parameters
    ----------
    x : float
        Length [mm].
    """


def _private(z):
    pass


class Table:
    """A public class."""

    def scaled(self, factor):
        """No parameters section."""

    @classmethod
    def build(cls, n):
        """Build.

        Parameters
        ----------
        n : int
            Size.
        """

    @staticmethod
    def bare(k):
        pass
'''


@pytest.mark.parametrize("name", ["volcal._fake_doc", "volcal.cli._fake_doc"])
def test_gate_on_a_synthetic_module(monkeypatch, name):
    module = types.ModuleType(name)
    exec(compile(_FAKE_SOURCE, name, "exec"), module.__dict__)
    monkeypatch.setitem(sys.modules, name, module)
    problems = _undocumented(name)
    if _is_cli(name):  # only docstrings are required in the CLI
        assert problems == [f"{name}.Table.bare: no docstring"]
    else:
        assert problems == [
            f"{name}.Table.bare: no docstring",
            f"{name}.Table.scaled: undocumented parameters factor",
            f"{name}.half: undocumented parameters y",
        ]


@pytest.mark.parametrize("module_name", _modules())
def test_public_callables_document_their_parameters(module_name: str):
    problems = _undocumented(module_name)
    assert not problems, "\n".join(problems)
