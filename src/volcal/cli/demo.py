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
    replace: bool = typer.Option(False, "--replace", help="The report/ or compensation/ "
                                 "folder of an earlier demo holds files volcal did not "
                                 "write there: move them into its backup/<UTC time>/ "
                                 "instead of refusing."),
) -> None:
    """Plan, simulate, identify, compensate, rehearse the as-left, report a virtual machine."""
    from volcal.cli._common import note_moved
    from volcal.compensate.manifest import MANIFEST
    from volcal.io.folders import manifest_files
    from volcal.io.paths import check_output_folder, prepare_output_folder
    from volcal.report.writer import written_files

    check_output_folder(output, "demo", lambda p: (p / "session" / "session.toml").is_file())
    # the demo replaces its report/ and compensation/ folders whole: the user's files
    # there are refused (or moved aside), as by `volcal report` and `volcal compensate`
    for sub, what, own, written in (
            ("compensation", "compensation", lambda p: (p / MANIFEST).is_file(),
             manifest_files(MANIFEST, "files")),
            ("report", "report", lambda p: (p / "report.html").is_file(), written_files)):
        moved = prepare_output_folder(output / sub, what, own, written=written,
                                      replace=replace)
        if moved is not None:
            note_moved(output / sub, moved)
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
    cert = out.report.folder / "certificate.pdf"
    if cert.is_file():
        console.print(f"[bold]Certificate:[/] {cert.resolve()}", soft_wrap=True)


def register(app: typer.Typer) -> None:
    """Add the commands of this module to the app."""
    app.command("demo")(demo_cmd)
