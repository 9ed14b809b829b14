"""Kind ``rotary``: angular positioning of one rotary axis (ISO 230-2 for rotary axes).

An angular interferometer on a rotary calibrator (target ``rotary_calibrator``: Renishaw
XR20) or against a precision index table (``index_table``: Keysight 5530 360-tooth
table) reads the angular positioning error of one rotary axis at each commanded angle.

Session keys: ``axis`` (``"a"``, ``"b"``, ``"c"``), ``range_deg = [min, max]`` (default
``[0, 360]``), ``modulo`` (full circle, default true), ``mounting`` (``"on_axis"``,
default, or ``"off_axis"`` with ``eccentricity_mm``); CSV ``target_deg, run, direction,
deviation_urad`` (``deviation_arcsec`` accepted), ``missed`` for a missed capture
(:mod:`volcal.session.rotary`, ``docs/formats.md``). The sign: deviation = actual -
commanded angle, positive counter-clockwise looking from the positive end of the axis
towards the origin (ISO 841, ``docs/conventions.md``).

Its readings come in while the program turns the axis (``volcal capture``: the control's
angle of the axis matched with the commanded one, from the planned side, modulo 360 on a
full circle; the calibrator's reading in an angular unit, written in urad counted from the
first row, :attr:`from_first_row`; ``docs/capture.md``, "Rotary tests"), or from the
calibrator software's export (``volcal import FILE --session S --measurement ID``).

The kind does not enter the identification of the linear axes (:attr:`in_design` is
False): a rotary test is evaluated per axis (ISO 230-2; its ECC, EAA or EBB); the
location errors of rotary axes and 5-axis identification come with issue 28.
``Measurement.positions`` holds the fixed pose of the linear axes (zeros: not recorded),
the commanded angle is the column ``target_deg``.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError
from volcal.kinds.outside_design import OutsideDesignKind
from volcal.session.kinds import ReadContext, register_kind
from volcal.session.rotary import check_rotary_keys

__all__ = ["RotaryKind"]

AXIS_VECTOR = {"a": (1.0, 0.0, 0.0), "b": (0.0, 1.0, 0.0), "c": (0.0, 0.0, 1.0)}
"""Direction of each rotary axis' rotation vector (A about X, B about Y, C about Z)."""


class RotaryKind(OutsideDesignKind):
    """Angular positioning of a rotary axis (ISO 230-2), readings in urad."""

    name: ClassVar[str] = "rotary"
    targets: ClassVar[tuple[str, ...]] = ("rotary_calibrator", "index_table")
    own_targets: ClassVar[tuple[str, ...]] = ("rotary_calibrator", "index_table")
    value_column: ClassVar[str] = "deviation_urad"
    value_unit: ClassVar[str] = "urad"
    beam_in_session: ClassVar[bool] = False
    bidirectional: ClassVar[bool] = True
    standard: ClassVar[str | None] = "ISO 230-2"
    plan_tests: ClassVar[tuple[str, ...]] = ("rotary",)
    description: ClassVar[str] = ("angular positioning of a rotary axis: angular "
                                  "interferometer on a rotary calibrator or index table")
    captured_by: ClassVar[str] = ""  # volcal capture turns with the axis (docs/capture.md)
    from_first_row: ClassVar[bool] = True
    evaluated_by: ClassVar[str] = ("ISO 230-2 per axis, volcal evaluate session (its table: "
                                   "volcal compensate --session)")

    # -- session -----------------------------------------------------------------------
    def read(self, entry: dict[str, Any], ctx: ReadContext) -> Any:
        """The entry's keys and its CSV (``target_deg``, ``deviation_urad``...).

        Parameters
        ----------
        entry : dict
            The ``[[measurements]]`` entry as parsed.
        ctx : ReadContext
            Its checked keys and the session's context.
        """
        from volcal.session.format import Measurement, _drop_missed
        from volcal.session.rotary import read_rotary_axes, read_rotary_csv

        axes = read_rotary_axes(ctx.machine, ctx.toml_path) if ctx.machine else []
        keys = check_rotary_keys(entry, ctx.toml_path, ctx.where, axes)
        meta = {k: v for k, v in entry.items()
                if k not in ("id", "kind", "target", "file", "tool_offset_mm",
                             "beam_direction")}
        r = read_rotary_csv(ctx.csv_path)
        lo, hi = keys["range_deg"]
        t = r.target_deg
        bad = np.flatnonzero((t < lo - 1e-9) | (t > hi + 1e-9))
        if bad.size:
            raise VolcalInputError(f"target {t[bad[0]]:g} deg outside the axis' range_deg "
                                   f"[{lo:g}, {hi:g}]", ctx.csv_path, int(r.rows[bad[0]]),
                                   "target_deg")
        rows = _as_rows(r)
        if ctx.require_deviation:
            if rows.deviation is not None and rows.missed.any():
                from volcal.session.format import MISSED_META

                meta[MISSED_META] = [
                    {"row": int(r.rows[i]), "position_mm": [0.0, 0.0, 0.0],
                     "target_deg": float(t[i]),
                     **({"run": int(r.columns["run"][i])} if "run" in r.columns else {}),
                     **({"direction": str(r.columns["direction"][i])}
                        if "direction" in r.columns else {})}
                    for i in np.flatnonzero(r.missed)]
            rows = _drop_missed(rows, ctx.csv_path, ctx.notes)
        n = rows.positions.shape[0]
        return Measurement(ctx.id, self.name, ctx.target, np.zeros((n, 3)), rows.deviation,
                           np.array(AXIS_VECTOR[keys["axis"]]), ctx.tool_offset, ctx.file,
                           rows.columns, meta, rows.rows)

    def csv_text(self, m: Any) -> str | None:
        """``target_deg, run, direction, deviation_urad`` [deg, -, -, urad].

        Parameters
        ----------
        m : Measurement
            The measurement.
        """
        from volcal.session.rotary import rotary_csv

        return rotary_csv(m.columns["target_deg"], m.deviation, m.columns)

    def csv_values(self, m: Any) -> tuple[str, NDArray[np.float64] | None, str]:
        """The reading column ``deviation_urad`` [urad].

        Parameters
        ----------
        m : Measurement
            The measurement.
        """
        return self.value_column, m.deviation, "{:.6f}"

    # -- forward model -----------------------------------------------------------------
    def exact(self, machine: Any, m: Any, setup: Any = None) -> NDArray[np.float64]:
        """Exact readings of the virtual rotary axis [urad] (:mod:`volcal.measure.rotary`).

        Parameters
        ----------
        machine : MachineErrors
            The machine (its linear errors do not enter an angular positioning reading).
        m : Measurement
            The measurement.
        setup : RotarySetup, optional
            The axis and mounting drawn by :meth:`simulate` (part of the truth); None: the
            machine's ``rotary`` axes if it has them (``machine.rotary[axis]``), else a
            perfect axis.
        """
        from volcal.measure.rotary import RotarySetup, rotary_exact

        if setup is None:
            axes = getattr(machine, "rotary", None) or {}
            e = axes.get(m.meta["axis"])
            setup = None if e is None else RotarySetup(e)
        return rotary_exact(setup, m.columns["target_deg"], m.columns.get("direction"))

    def simulate(self, m: Any, machine: Any, rng: np.random.Generator, options: Any,
                 shared: dict[str, Any]) -> Any:
        """Readings of a virtual rotary axis (one per axis, shared by its tests) [urad].

        The axis is drawn once per axis name (:func:`volcal.measure.rotary.random_rotary_axis`)
        unless the machine carries it (``machine.rotary``); an off-axis mounting adds its
        eccentricity's once-per-revolution term; noise of ``options.noise_um`` read as
        urad.

        Parameters
        ----------
        m : Measurement
            Planned measurement.
        machine : MachineErrors
            The virtual machine.
        rng : numpy.random.Generator
            The simulation's generator.
        options : SimulationOptions
            Noise, dwell.
        shared : dict
            State shared by the measurements of one simulation.

        Returns
        -------
        RotarySetup
            The axis and mounting drawn (part of the truth).
        """
        from volcal.measure.rotary import RotarySetup, random_rotary_axis

        keys = check_rotary_keys(m.meta, None, m.id)
        axes = shared.setdefault("rotary", {})
        given = (getattr(machine, "rotary", None) or {}).get(keys["axis"])
        if keys["axis"] not in axes:
            axes[keys["axis"]] = given or random_rotary_axis(rng, keys["axis"],
                                                             keys["range_deg"], keys["modulo"])
        setup = RotarySetup(axes[keys["axis"]], keys["eccentricity_mm"],
                            float(rng.uniform(0.0, 2 * np.pi)))
        dev = self.exact(machine, m, setup)
        if not options.reversal:
            dev = self.exact(machine, m, RotarySetup(
                _no_reversal(setup.axis), setup.eccentricity_mm, setup.eccentricity_phase_rad))
        if options.noise_um > 0:
            noise = rng.normal(0.0, options.noise_um, m.n)
            dev = dev + noise - noise[0]
        m.deviation = dev - dev[0]
        m.columns["time_s"] = np.arange(m.n) * options.dwell_s
        return setup

    # -- plan, program -----------------------------------------------------------------
    def plan(self, test: str, options: Any, only: str | None = None) -> list[Any]:
        """One bidirectional test per rotary axis (or the axis ``only``).

        Parameters
        ----------
        test : str
            ``'rotary'``.
        options : volcal.plan.planner.PlanOptions
            The plan's options (``runs``, ``steps``, ``rotary``: axes and targets).
        only : str or None
            ``'a'``, ``'b'`` or ``'c'``; None: every axis of the plan (C by default).
        """
        from volcal.plan.rotary import rotary_tests

        return rotary_tests(options, only)

    def program_setup_lines(self, m: Any) -> list[str] | None:
        """The calibrator's set-up in the program header.

        Parameters
        ----------
        m : Measurement
            The measurement.
        """
        axis = m.meta["axis"].upper()
        what = ("ROTARY CALIBRATOR (XR20) WITH ANGULAR OPTICS" if m.target == "rotary_calibrator"
                else "INDEX TABLE WITH ANGULAR OPTICS")
        mount = m.meta.get("mounting", "on_axis")
        ecc = m.meta.get("eccentricity_mm")
        return [f"{what} ON AXIS {axis}",
                "MOUNTED ON AXIS" if mount == "on_axis"
                else f"MOUNTED OFF AXIS, ECCENTRICITY {ecc:g} MM"]


    def program_text(self, m: Any, dialect: str, name: str, number: int, options: Any
                     ) -> tuple[str, list[str]] | None:
        """Incremental turns with overruns and dwells (:mod:`volcal.program.rotary`).

        Parameters
        ----------
        m : Measurement
            The measurement.
        dialect : str
            The dialect.
        name : str
            Program name.
        number : int
            Fanuc program number.
        options : volcal.program.steps.ProgramOptions
            Dwell, feed [deg/min], ``overrun_deg``, decimals, safe Z.
        """
        from volcal.program.rotary import rotary_program

        return rotary_program(m, dialect, name, number, options)


    def evaluate_positioning(self, m: Any, edition: str, budget: Any) -> Any:
        """ISO 230-2 of the rotary axis [urad] (:mod:`volcal.standards.iso230_2_rotary`).

        Parameters
        ----------
        m : Measurement
            The measurement.
        edition : str
            ISO 230-2 edition.
        budget : Budget or None
            For U (its ``[angular]`` section).
        """
        from volcal.standards.iso230_2_rotary import evaluate_rotary_measurement

        return evaluate_rotary_measurement(m, edition, budget)

    def report_section(self, inp: Any) -> Any:
        """The rotary section of the report (:mod:`volcal.report.rotary`).

        Parameters
        ----------
        inp : volcal.report.sections.ReportInputs
            The session and its results.
        """
        from volcal.report.rotary import rotary_section

        return rotary_section(inp)


def _no_reversal(e: Any) -> Any:
    from dataclasses import replace

    return replace(e, reversal_urad=0.0)


def _as_rows(r: Any) -> Any:
    """The rotary rows as the session reader's rows (positions: zeros)."""
    from volcal.session.format import _Rows

    return _Rows(np.zeros((r.target_deg.size, 3)), r.deviation_urad, dict(r.columns), r.rows,
                 r.missed)


ROTARY = register_kind(RotaryKind)
