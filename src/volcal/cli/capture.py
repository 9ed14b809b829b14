"""``volcal capture``: readings taken while the part programs run, one row per dwell."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.markup import escape

from volcal import defaults as D
from volcal.cli._options import cli_spelling

console = Console(soft_wrap=True)
err_console = Console(stderr=True, soft_wrap=True)

SOURCES_HELP = ("control: sim, linuxcnc[:INI], opcua:opc.tcp://HOST:4840; laser: sim, "
                "stream:tcp://HOST:PORT, stream:/dev/ttyUSB0, stream:- (standard input), "
                "file:PATH, typed; ';unit=arcsec' for a rotary test's angles "
                "(docs/capture.md)")


def capture(
    session: Annotated[Path, typer.Argument(help="The planned session folder.")],
    control: Annotated[str, typer.Option(help="Control SOURCE: sim, linuxcnc[:INI], "
                                         "opcua:opc.tcp://HOST:4840.")],
    laser: Annotated[str, typer.Option(help="Laser SOURCE: sim, stream:tcp://HOST:PORT, "
                                       "stream:/dev/ttyUSB0, stream:-, file:PATH, typed; "
                                       "the unit of a line without one after ';': "
                                       "unit=um (a length), unit=arcsec or unit=urad (a "
                                       "rotary test's angular reading).")],
    measurement: Annotated[list[str] | None, typer.Option(
        help="Capture this measurement (repeat; default: every one, in the plan's order).")
    ] = None,
    output: Annotated[Path | None, typer.Option(
        "-o", "--output", help="Capture into this folder (a copy of the planned session; "
        "an existing capture there is resumed) instead of SESSION itself.")] = None,
    programs: Annotated[Path | None, typer.Option(
        help="The program folder (volcal program -o): its dwell, feed and overrun.")] = None,
    dwell_s: Annotated[float | None, typer.Option(
        help="Programmed dwell [s] (default: from --programs, else 4).")] = None,
    feed: Annotated[float | None, typer.Option(
        help="Programmed feed [mm/min] (default: from --programs, else 2000).")] = None,
    overrun_mm: Annotated[float | None, typer.Option(
        help="Programmed overrun [mm] (default: from --programs, else 5).")] = None,
    window_mm: Annotated[float, typer.Option(help="Target window [mm].")
                         ] = D.CAPTURE_WINDOW_MM,
    window_deg: Annotated[float, typer.Option(
        help="Target window of a rotary test's axis [deg].")] = D.CAPTURE_WINDOW_DEG,
    stable_s: Annotated[float, typer.Option(
        help="Time both signals must be stable before a point is taken [s].")
    ] = D.CAPTURE_STABLE_S,
    k_sigma: Annotated[float, typer.Option(
        help="Stability threshold in standard errors of the noise.")] = D.CAPTURE_K_SIGMA,
    laser_noise: Annotated[float, typer.Option(
        help="Floor of the laser noise [um or urad] (its resolution).")
    ] = D.CAPTURE_LASER_NOISE,
    control_noise_mm: Annotated[float, typer.Option(
        help="Floor of the control position noise [mm].")] = D.CAPTURE_CONTROL_NOISE_MM,
    max_gap_s: Annotated[float, typer.Option(
        help="Longest polling gap tolerated inside a stable window [s].")
    ] = D.CAPTURE_MAX_GAP_S,
    poll_s: Annotated[float, typer.Option(help="Pause between two polls [s].")
                      ] = D.CAPTURE_POLL_S,
    timeout_s: Annotated[float | None, typer.Option(
        help="Stop (resume later) when nothing is decided for this long [s].")] = None,
    speed: Annotated[float | None, typer.Option(
        help="Simulated control: simulated seconds per second (default: as fast as "
        "possible).")] = None,
    serve: Annotated[bool, typer.Option(
        "--serve", help="Serve the technician's page while capturing (docs/capture_page.md)."
    )] = False,
    host: Annotated[str, typer.Option(
        help="Address the page binds (127.0.0.1: this computer only).")] = "127.0.0.1",
    port: Annotated[int, typer.Option(help="TCP port of the page (0: any free one).")
                    ] = 8765,
    again: Annotated[bool, typer.Option(
        "--again", help="Capture the --measurement(s) again from their first reading; their "
        "earlier capture (file and journal) is kept in SESSION/backup/<UTC time>/.")] = False,
) -> None:
    """Capture the readings while the part programs run: one row per dwell (resumable)."""
    from volcal.steps.capture import capture as step

    page = None
    if serve:  # the technician's page (volcal.capture.page): observer and typed readings
        from volcal.capture.page.server import Page

        page = Page(session.resolve().name, control, laser, host, port, window_mm=window_mm)
        console.print(f"page: {page.url}")
    try:
        r = step(session, control=control, laser=laser, measurement=measurement,
                 output=output, programs=programs, dwell_s=dwell_s, feed=feed,
                 overrun_mm=overrun_mm, window_mm=window_mm, window_deg=window_deg,
                 stable_s=stable_s,
                 k_sigma=k_sigma, laser_noise=laser_noise, control_noise_mm=control_noise_mm,
                 max_gap_s=max_gap_s, poll_s=poll_s, timeout_s=timeout_s, speed=speed,
                 observer=page.observer if page else None,
                 extras=page.extras if page else None, again=again)
    except BaseException as e:
        if page is not None:
            page.close("capture stopped", str(e) or type(e).__name__)
        raise
    if page is not None:
        page.close("captured" if r.complete else "capture stopped")
    for mid in r.skipped:
        console.print(f"{mid}: already complete (journal), skipped")
    for o in r.outcomes:
        missed = f", {len(o.missed)} missed" if o.missed else ""
        replayed = f", {o.replayed} replayed" if o.replayed else ""
        console.print(f"{o.measurement}: {o.accepted + len(o.missed)} of {o.planned} "
                      f"readings recorded ({o.accepted} accepted{missed}{replayed})")
    for n in r.notes:
        err_console.print(f"[yellow]note:[/] {escape(n)}", highlight=False)
    console.print(f"{'captured' if r.complete else 'capture stopped'} -> {r.folder}")
    if not r.complete:
        raise typer.Exit(3)
    if r.unreadable:
        err_console.print(f"error: {', '.join(r.unreadable)}: captured to the end, but "
                          "unreadable (see the notes above)", highlight=False)
        raise typer.Exit(1)


def register(app: typer.Typer) -> None:
    """Add the commands of this module to the app."""
    app.command("capture")(cli_spelling(capture))
