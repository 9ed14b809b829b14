"""The rooms of volcal and their import directions (docs/architecture.md).

The import-linter contracts of pyproject.toml (``[tool.importlinter]``) run here, so a
broken contract fails ``make test`` as it fails ``make lint``: the layers from the model up
to the command line, no import cycle, and no database, dataframe or plotting library
imported by the core.
"""

from __future__ import annotations

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
