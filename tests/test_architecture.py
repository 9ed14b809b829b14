"""The rooms of volcal and their import directions (docs/architecture.md).

The import-linter contracts of pyproject.toml (``[tool.importlinter]``) run here, so a
broken contract fails ``make test`` as it fails ``make lint``: the layers from the model up
to the command line, no import cycle, and no database, dataframe or plotting library
imported by the core.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _lint_imports(config: Path) -> subprocess.CompletedProcess:
    code = ("import sys\nfrom importlinter.cli import lint_imports_command\n"
            "sys.argv = ['lint-imports', '--no-cache', '--config', sys.argv[1]]\n"
            "lint_imports_command()\n")
    return subprocess.run([sys.executable, "-c", code, str(config)], cwd=ROOT,
                          capture_output=True, text=True)


def test_import_contracts_are_kept():
    """lint-imports: every contract of pyproject.toml kept (import-linter, the test extra)."""
    r = _lint_imports(ROOT / "pyproject.toml")
    assert "Contracts: 3 kept, 0 broken." in r.stdout, r.stdout + r.stderr
    assert r.returncode == 0


def test_a_broken_contract_fails(tmp_path):
    """The contracts can fail: the layers turned upside down are reported broken."""
    text = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    head, sep, layers = text.partition('layers = [\n')
    block, end, rest = layers.partition("]\n")
    lines = block.splitlines(keepends=True)
    upside_down = head + sep + "".join(reversed(lines)) + end + rest
    (tmp_path / "pyproject.toml").write_text(upside_down, encoding="utf-8")
    r = _lint_imports(tmp_path / "pyproject.toml")
    assert r.returncode == 1, r.stdout + r.stderr
    assert "volcal.model is not allowed to import volcal.errors" in r.stdout


def _global_matplotlib_state(path: Path) -> list[str]:
    """Imports of pyplot and calls of matplotlib.use / pyplot.switch_backend in a file."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [a.name for a in node.names if a.name.startswith("matplotlib.pyplot")]
        elif isinstance(node, ast.ImportFrom):
            mod = node.module or ""
            if mod.startswith("matplotlib.pyplot") or (
                    mod == "matplotlib" and any(a.name == "pyplot" for a in node.names)):
                out.append(f"from {mod} import ...")
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) \
                and node.func.attr in ("use", "switch_backend") \
                and isinstance(node.func.value, ast.Name) \
                and node.func.value.id in ("matplotlib", "mpl", "plt"):
            out.append(f"{node.func.value.id}.{node.func.attr}()")
    return out


def test_no_module_touches_pyplot_or_the_backend(tmp_path):
    """volcal draws on its own Agg canvases: the caller's pyplot and backend stay theirs."""
    src = ROOT / "src" / "volcal"
    found = {str(p.relative_to(src)): _global_matplotlib_state(p)
             for p in sorted(src.rglob("*.py"))}
    assert {k: v for k, v in found.items() if v} == {}
    # the check finds what it looks for (history/trend.py did both until issue 25)
    probe = tmp_path / "probe.py"
    probe.write_text("def f():\n    import matplotlib\n\n    matplotlib.use('Agg')\n"
                     "    import matplotlib.pyplot as plt\n", encoding="utf-8")
    assert sorted(_global_matplotlib_state(probe)) == ["matplotlib.pyplot", "matplotlib.use()"]
