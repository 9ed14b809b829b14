"""The ``volcal`` command line (typer). Thin: every command calls the library.

Each module of this package defines ``register(app)``; they are discovered
automatically, so a new command is a new module. User mistakes
(:class:`~volcal.errors.VolcalInputError`) are printed without a traceback, exit code 2.
"""

from __future__ import annotations

import importlib
import pkgutil
import sys

import typer
from rich.console import Console
from rich.markup import escape

from volcal.errors import VolcalInputError

app = typer.Typer(
    name="volcal",
    help="Laser-interferometer calibration of machine tools and CMMs: plan, program, "
    "simulate, identify, evaluate, compensate, report.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # plain help: units such as '[s]', '[mm]' are not Rich markup
)
err_console = Console(stderr=True, soft_wrap=True)

_ORDER = ["plan", "program", "simulate", "classic", "identify", "evaluate", "budget", "env",
          "compensate", "importer", "report", "demo"]


def _register_all() -> None:
    names = [m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_")]
    names.sort(key=lambda n: (_ORDER.index(n) if n in _ORDER else len(_ORDER), n))
    for name in names:
        mod = importlib.import_module(f"{__name__}.{name}")
        if hasattr(mod, "register"):
            mod.register(app)


_register_all()


def main() -> None:
    """Entry point of the ``volcal`` console script."""
    try:
        app()  # standalone mode: usage errors are reported by typer with exit code 2
    except VolcalInputError as exc:
        err_console.print(f"[bold red]error:[/] {escape(str(exc))}", highlight=False)
        sys.exit(2)
    except KeyboardInterrupt:
        err_console.print("aborted")
        sys.exit(130)
    except OSError as exc:  # disk full, permissions, a file vanishing while we write
        err_console.print(f"[bold red]error:[/] {escape(str(exc))} (nothing was replaced: "
                          "volcal writes its outputs atomically)", highlight=False)
        sys.exit(1)
