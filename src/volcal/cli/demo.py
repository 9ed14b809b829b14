"""``volcal demo``: the whole flow on a virtual machining centre, in one command."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

console = Console(soft_wrap=True)  # no line breaks inside paths


def demo_cmd(
    output: Path = typer.Option(Path("demo-output"), "-o", "--output",
                                help="Folder for the session, model and report."),
    seed: int = typer.Option(7, min=0, help="Seed of the virtual machine and of the noise."),
) -> None:
    """Plan, simulate, identify, evaluate, compensate and report a virtual machine."""
    from volcal.io.paths import check_output_folder

    check_output_folder(output, "demo", lambda p: (p / "session" / "session.toml").is_file())
    from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    from volcal.demo import DEMO_STEPS, run_demo

    with Progress(SpinnerColumn(), TextColumn("{task.description:<40}"), BarColumn(),
                  TextColumn("{task.completed}/{task.total}"), TimeElapsedColumn(),
                  console=console) as progress:
        task = progress.add_task("demo", total=len(DEMO_STEPS))

        def step(name: str) -> None:
            progress.update(task, description=name)

        def done() -> None:
            progress.advance(task)

        out = run_demo(output, seed, on_step=step, on_done=done)
    for line in out.summary:
        console.print(line, highlight=False, soft_wrap=True)
    # soft_wrap: never break a path, the user copies it into a browser
    console.print(f"\n[bold]Report:[/] {out.report.html.resolve()}\n"
                  f"        {out.report.pdf.resolve()}", soft_wrap=True)


def register(app: typer.Typer) -> None:
    """Add the commands of this module to the app."""
    app.command("demo")(demo_cmd)
