"""Start-up: commands register lazily and import only what they use; ``volcal --version``.

Every check runs in a fresh interpreter and reads ``sys.modules`` after the command.
"""

from __future__ import annotations

import importlib.metadata
import json
import subprocess
import sys
from pathlib import Path

import pytest

from timing import scaled_timeout

# never loaded by a command that does not use them (plotting, templates, dataframes,
# databases, the GUM library, the estimator's optimiser)
HEAVY = ("matplotlib", "jinja2", "pandas", "sqlalchemy", "GTC", "scipy.optimize")

PROBE = """
import json, sys
sys.argv = ["volcal", *json.loads(sys.argv[1])]
from volcal.cli import main
try:
    main()
except SystemExit as exc:
    code = exc.code
else:
    code = 0
print(json.dumps({"rc": code, "modules": sorted(sys.modules)}))
"""


def loaded(*args: object) -> tuple[int, set[str], str]:
    """Run ``volcal ARGS`` in a fresh interpreter: exit code, modules loaded, stderr."""
    r = subprocess.run([sys.executable, "-c", PROBE, json.dumps([str(a) for a in args])],
                       capture_output=True, text=True, timeout=scaled_timeout(180))
    out = json.loads(r.stdout.strip().splitlines()[-1])
    return out["rc"], set(out["modules"]), r.stderr


def heavy(modules: set[str], names=HEAVY) -> list[str]:
    return sorted(n for n in names if n in modules or any(m.startswith(n + ".")
                                                           for m in modules))


def test_import_volcal_is_light():
    r = subprocess.run([sys.executable, "-c",
                        "import json, sys, volcal; print(json.dumps(sorted(sys.modules)))"],
                       capture_output=True, text=True, timeout=scaled_timeout(60))
    mods = set(json.loads(r.stdout))
    assert heavy(mods, ("matplotlib", "pandas", "sqlalchemy", "GTC", "scipy", "numpy",
                        "typer", "rich")) == []


def test_help_imports_no_command_module():
    rc, mods, _ = loaded("--help")
    assert rc == 0
    assert [m for m in mods if m.startswith("volcal.cli.")] == []
    assert heavy(mods, (*HEAVY, "numpy", "scipy")) == []


@pytest.mark.parametrize("args", [("predict", "--help"), ("identify", "--help"),
                                  ("evaluate", "--help"), ("evaluate", "iso230-6", "--help"),
                                  ("compensate", "--help"), ("plan", "--help")])
def test_a_command_imports_its_own_module_only(args):
    rc, mods, err = loaded(*args)
    assert rc == 0, err
    assert heavy(mods, (*HEAVY, "scipy")) == []
    cli = {m for m in mods if m.startswith("volcal.cli.")} - {"volcal.cli._common",
                                                               "volcal.cli._options"}
    from volcal.cli import COMMANDS

    assert cli == {f"volcal.cli.{COMMANDS[args[0]][0]}"}


def test_evaluate_and_predict_at_work_load_neither_plots_nor_the_estimator(tmp_path):
    from volcal.identify import load_model

    s = tmp_path / "S"
    assert subprocess.run([sys.executable, "-c", "from volcal.cli import main; main()",
                           "plan", "-o", str(s), "--travel", "0:300,0:200,0:100",
                           "--steps", "3", "--runs", "2"], capture_output=True).returncode == 0
    assert subprocess.run([sys.executable, "-c", "from volcal.cli import main; main()",
                           "simulate", str(s)], capture_output=True).returncode == 0
    rc, mods, err = loaded("evaluate", "session", s)
    assert rc == 0, err
    assert heavy(mods, (*HEAVY, "volcal.identify.api", "volcal.plot")) == []
    rc, mods, err = loaded("evaluate", "iso230-6", s)
    assert rc == 0, err
    assert heavy(mods, (*HEAVY, "volcal.identify.api", "volcal.plot")) == []
    model = load_model(Path(__file__).parents[1] / "identify" / "data" / "model_v2.json")
    model.to_json(tmp_path / "m.json")
    (tmp_path / "p.csv").write_text("x_mm,y_mm,z_mm\n10,20,30\n")
    rc, mods, err = loaded("predict", tmp_path / "m.json", "--points", tmp_path / "p.csv",
                           "-o", tmp_path / "e.csv")
    assert rc == 0, err
    assert (tmp_path / "e.csv").read_text().count("\n") == 2
    assert heavy(mods, (*HEAVY, "scipy", "volcal.identify.api")) == []


def test_help_lists_every_command_as_the_commands_themselves_say():
    """The lazy listing (from the table) is what the loaded commands print."""
    import typer

    from volcal.cli import COMMANDS, app

    def listing(group) -> str:
        ctx = typer.Context(group, info_name="volcal")
        text = group.get_help(ctx)
        return text[text.index("Commands:"):]

    lazy = typer.main.get_command(app)
    first = listing(lazy)
    assert lazy.commands == {}  # nothing imported to list them
    eager = typer.main.get_command(app)
    names = eager.list_commands(None)
    assert set(names) <= set(COMMANDS)
    for name in names:
        assert eager.get_command(None, name) is not None, name
        assert eager.commands[name].name == name
    assert listing(eager) == first
    for name in ("plan", "program", "simulate", "import", "identify", "predict", "evaluate",
                 "compensate", "report", "demo", "classic", "env", "advise"):
        assert f"\n  {name} " in first


def test_version_is_the_package_metadata():
    r = subprocess.run([sys.executable, "-c", "from volcal.cli import main; main()",
                        "--version"], capture_output=True, text=True, timeout=scaled_timeout(60))
    assert r.returncode == 0, r.stderr
    want = importlib.metadata.version("volcal")
    assert r.stdout.strip() == f"volcal {want}"
    import volcal

    assert volcal.__version__ == want


def test_full_app_registers_every_command_for_introspection():
    from volcal.cli import COMMANDS, full_app

    full = full_app()
    names = {c.name for c in full.registered_commands} | {g.name for g in
                                                         full.registered_groups}
    import typer

    from volcal.cli import app

    assert names == set(typer.main.get_command(app).list_commands(None))
    assert names <= set(COMMANDS) and {"identify", "predict", "evaluate"} <= names
