"""The ``volcal`` command line (typer). Thin: every command calls the library.

Commands register lazily: :data:`COMMANDS` maps each command name to the module of this
package that defines it (its ``register(app)``) and to its one-line help, so ``volcal
--help`` lists every command without importing any of them, and ``volcal predict``
imports ``volcal.cli.identify`` only (start-up in milliseconds, not the seconds that
numpy, scipy, matplotlib and jinja2 take together). A module of this package that is
not in the table is still found and registered, eagerly (add it to the table: the tests
check that each command imports its own module only); an entry whose module is not
there is left out. User mistakes
(:class:`~volcal.errors.VolcalInputError`) are printed without a traceback, exit code 2;
a step's :class:`~volcal.errors.ParameterError` names the command line's option
(``volcal.cli._options.OPTIONS``).
"""

from __future__ import annotations

import importlib
import pkgutil
import sys
import warnings
from difflib import get_close_matches
from typing import Any

import typer
from typer.core import TyperGroup

from volcal.errors import VolcalInputError

#: Command name -> (module of ``volcal.cli``, one-line help as ``volcal --help`` lists it).
#: The help is the command's own (its docstring or its group's help); the tests check that
#: they agree, so the listing is the same as if every module were imported.
COMMANDS: dict[str, tuple[str, str]] = {
    "plan": ("plan", "Write a session skeleton: the commanded poses of every test, "
             "deviations empty."),
    "simulate": ("plan", "Fill the deviations from a virtual machine; keep its truth in "
                 "SESSION/truth/."),
    "program": ("program", "Write one part program per measurement: planned poses in "
                "order, a dwell at each."),
    "advise": ("identify", "Before measuring: what the planned tests will and will not "
               "determine."),
    "identify": ("identify", "Identify the machine's errors from the session; write "
                 "MODEL.json."),
    "predict": ("identify", "Predict the volumetric error and its uncertainty at points."),
    "locate": ("locate", "Identify the rotary axes' location errors from probe-on-sphere "
               "tests."),
    "budget": ("budget", "Write the budget template, or check a budget and show it at a "
               "length."),
    "compensate": ("compensate", "Write compensation tables of a model for a controller, "
                   "resampled onto its grid."),
    "import": ("importer", "Add a measurement from a laser CSV export to a session "
               "(atomically)."),
    "report": ("report", "Write the calibration report of a session as self-contained "
               "HTML and as PDF."),
    "demo": ("demo", "Plan, simulate, identify, compensate, rehearse the as-left, report a "
             "virtual machine."),
    "classic": ("classic", "The seeds' classic solvers: Abbe lines, body diagonals, "
                "sequential step diagonal (docs/classic.md)."),
    "evaluate": ("evaluate", "Evaluate measurements to the standards (ISO 230-2, VDI/DGQ "
                 "3441, ISO 230-6, ISO 230-1 volumetric indices)."),
    "env": ("env", "Environment: refractive index of air, drift check."),
    "capture": ("capture", "Capture the readings while the part programs run: one row per "
                "dwell (resumable)."),
    "history": ("history", "Calibration history: add, list, show, trend, compare, due, "
                "fleet, export, verify (SQLite by default, PostgreSQL by URL)."),
}


def version() -> str:
    """The installed version of volcal.

    Returns
    -------
    str
        ``importlib.metadata.version("volcal")``; ``volcal.__version__`` when the package
        is not installed.
    """
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as _version

    try:
        return _version("volcal")
    except PackageNotFoundError:  # run from a source tree without installing
        from volcal import __version__

        return __version__


class LazyGroup(TyperGroup):
    """The root command group: imports a command's module when that command is used.

    ``list_commands`` and the help listing read :data:`COMMANDS`; ``get_command`` imports
    the module (``volcal.cli.<module>``), lets it register on a scratch Typer app and keeps
    the click commands it made.
    """

    def __init__(self, **attrs: Any) -> None:
        super().__init__(**attrs)
        present = _command_modules()
        self.lazy: dict[str, tuple[str, str]] = {n: v for n, v in COMMANDS.items()
                                                 if v[0] in present}
        listed = {m for m, _ in COMMANDS.values()}
        for extra in sorted(present - listed):  # added without a table entry: eagerly
            self._load(extra)

    def _load(self, module: str) -> None:
        mod = importlib.import_module(f"{__name__}.{module}")
        register = getattr(mod, "register", None)
        if register is None:
            return
        scratch = typer.Typer(add_completion=False, pretty_exceptions_enable=False,
                              rich_markup_mode=None)
        register(scratch)
        for name, cmd in typer.main.get_group(scratch).commands.items():
            self.commands.setdefault(name, cmd)

    def list_commands(self, ctx: Any) -> list[str]:
        """Every command name: the table's in its order, then any registered eagerly."""
        return [*self.lazy, *(n for n in self.commands if n not in self.lazy)]

    def get_command(self, ctx: Any, cmd_name: str) -> Any:
        """The click command of ``cmd_name``, importing its module on first use."""
        if cmd_name not in self.commands and cmd_name in self.lazy:
            self._load(self.lazy[cmd_name][0])
        return self.commands.get(cmd_name)

    def format_commands(self, ctx: Any, formatter: Any) -> None:
        """The "Commands" section of ``volcal --help``, from the table (nothing imported)."""
        names = self.list_commands(ctx)
        if not names:
            return
        from typer._click.utils import make_default_short_help

        limit = formatter.width - 6 - max(len(n) for n in names)
        rows = []
        for name in names:
            cmd = self.commands.get(name)
            if cmd is not None:
                if cmd.hidden:
                    continue
                rows.append((name, cmd.get_short_help_str(limit)))
            else:
                rows.append((name, make_default_short_help(self.lazy[name][1], limit).strip()))
        with formatter.section("Commands"):
            formatter.write_dl(rows)

    def resolve_command(self, ctx: Any, args: list[str]) -> Any:
        """Resolve the command; a mistyped name gets the closest names as suggestions."""
        from typer._click.exceptions import UsageError

        try:
            return self._click_resolve_command(ctx, args)
        except UsageError as e:
            if self.suggest_commands and args:
                matches = get_close_matches(args[0], self.list_commands(ctx))
                if matches:
                    e.message = (e.message.rstrip(".") + ". Did you mean "
                                 + ", ".join(f"{m!r}" for m in matches) + "?")
            raise


def _command_modules() -> set[str]:
    """The command modules of this package (found on disk, not imported)."""
    return {m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_")}


app = typer.Typer(
    name="volcal",
    cls=LazyGroup,
    help="Laser-interferometer calibration of machine tools and CMMs: plan, program, "
    "simulate, identify, evaluate, compensate, report.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # plain help: units such as '[s]', '[mm]' are not Rich markup
)


def full_app() -> typer.Typer:
    """A Typer app with every command registered (all modules imported).

    For introspection (documentation, the tests that compare the command line's defaults
    with Python's): :data:`app` registers its commands lazily, so its
    ``registered_commands`` are empty until the command line runs.

    Returns
    -------
    typer.Typer
        A new app; ``registered_commands`` and ``registered_groups`` hold every command.
    """
    out = typer.Typer(name="volcal", add_completion=False, pretty_exceptions_enable=False,
                      rich_markup_mode=None)
    for module in dict.fromkeys([m for m, _ in COMMANDS.values() if m in _command_modules()]
                                + sorted(_command_modules())):
        mod = importlib.import_module(f"{__name__}.{module}")
        if hasattr(mod, "register"):
            mod.register(out)
    return out


def _print_version(value: bool) -> None:
    if value:
        print(f"volcal {version()}")
        raise typer.Exit()


@app.callback()
def _root(
    show_version: bool = typer.Option(False, "--version", callback=_print_version,
                                      is_eager=True, help="Print the version and exit."),
) -> None:
    """Laser-interferometer calibration of machine tools and CMMs."""


def _err_console() -> Any:
    from rich.console import Console

    return Console(stderr=True, soft_wrap=True)


def _show_warning(message: Any, category: type[Warning], filename: str, lineno: int,
                  file: Any = None, line: str | None = None) -> None:
    """Print volcal's own warnings as one plain line on stderr (others as Python does)."""
    if category.__module__.startswith("volcal"):
        from rich.markup import escape

        _err_console().print(f"[yellow]warning:[/] {escape(str(message))}", highlight=False)
    else:
        _python_showwarning(message, category, filename, lineno, file, line)


_python_showwarning = warnings.showwarning


def main() -> None:
    """Entry point of the ``volcal`` console script."""
    warnings.showwarning = _show_warning
    try:
        app()  # standalone mode: usage errors are reported by typer with exit code 2
    except VolcalInputError as exc:
        from rich.markup import escape

        from volcal.errors import ParameterError

        if isinstance(exc, ParameterError):  # a step's parameter, named as the CLI's option
            from volcal.cli._options import OPTIONS

            exc = exc.spelled(OPTIONS)

        _err_console().print(f"[bold red]error:[/] {escape(str(exc))}", highlight=False)
        sys.exit(2)
    except KeyboardInterrupt:
        _err_console().print("aborted")
        sys.exit(130)
    except OSError as exc:  # disk full, permissions, a file vanishing while we write
        from rich.markup import escape

        _err_console().print(f"[bold red]error:[/] {escape(str(exc))} (nothing was replaced: "
                             "volcal writes its outputs atomically)", highlight=False)
        sys.exit(1)
