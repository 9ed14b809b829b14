"""Kind ``multilateration``: a tracking interferometer reading its distance to the tool.

Session keys: ``station_mm`` (the tracker's pivot [mm], required), ``station_u_mm`` (how
well it is placed [mm]); target ``cat_eye``; CSV ``length_mm`` (change of the
station-to-reflector distance [mm], :mod:`volcal.session.multilateration`). Forward model
:mod:`volcal.measure.multilateration`; rows with the station's three coordinates as shared
nuisances with their prior (:mod:`volcal.identify.multilateration`); planned by
``--tests multilateration`` (:mod:`volcal.plan.multilateration`).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from volcal.session.kinds import Kind, ReadContext, RowBlock, register_kind

__all__ = ["MultilaterationKind"]


class MultilaterationKind(Kind):
    """Tracking interferometer (multilateration) at a station."""

    name: ClassVar[str] = "multilateration"
    targets: ClassVar[tuple[str, ...]] = ("cat_eye",)
    own_targets: ClassVar[tuple[str, ...]] = ("cat_eye",)
    value_column: ClassVar[str] = "length_mm"
    beam_in_session: ClassVar[bool] = False
    along_beam: ClassVar[bool] = False
    captured_by: ClassVar[str] = ("a tracking interferometer records its own lengths: import "
                                  "its export (volcal import)")
    raw_readings: ClassVar[bool] = True
    plan_tests: ClassVar[tuple[str, ...]] = ("multilateration",)
    description: ClassVar[str] = "tracking interferometer: distance from a station"

    def read(self, entry: dict[str, Any], ctx: ReadContext) -> Any:
        """Station, tool offset and ``length_mm`` readings, as deviations [um].

        Parameters
        ----------
        entry : dict
            The ``[[measurements]]`` entry as parsed.
        ctx : ReadContext
            Its checked keys and the session's context.
        """
        from volcal.session.format import (
            MULTILATERATION_COLUMN,
            Measurement,
            _err,
            _vec3,
            read_measurement_csv,
        )
        from volcal.session.multilateration import DEFAULT_STATION_U_MM, deviation_from_length

        where, toml_path, offset = ctx.where, ctx.toml_path, ctx.tool_offset
        if "station_mm" not in entry:
            raise _err("missing station_mm = [x, y, z]: where the tracker's pivot stands [mm]",
                       toml_path, None, f"{where}.station_mm")
        station = _vec3(entry["station_mm"], toml_path, f"{where}.station_mm")
        u = entry.get("station_u_mm", DEFAULT_STATION_U_MM)
        if (isinstance(u, bool) or not isinstance(u, int | float)
                or not (math.isfinite(u) and u > 0)):
            raise _err(f"station_u_mm must be a positive number of mm, got {u!r}", toml_path,
                       None, f"{where}.station_u_mm")
        pos, length, cols = read_measurement_csv(ctx.csv_path, ctx.require_deviation,
                                                 value_column=MULTILATERATION_COLUMN)
        d = np.linalg.norm(pos + offset - station, axis=1)
        if np.min(d) < 1.0:
            row = int(np.argmin(d)) + 2
            raise _err("the reflector comes within 1 mm of the station pivot: check "
                       "station_mm and tool_offset_mm", ctx.csv_path, row, "x_mm")
        dev = None if length is None else deviation_from_length(length, pos, offset, station)
        meta = {k: v for k, v in entry.items()
                if k not in ("id", "kind", "target", "file", "tool_offset_mm",
                             "beam_direction")}
        meta["station_mm"] = [float(v) for v in station]
        n = (pos[0] + offset - station) / d[0]
        return Measurement(ctx.id, self.name, ctx.target, pos, dev, n, offset, ctx.file, cols,
                           meta)

    def csv_values(self, m: Any) -> tuple[str, NDArray[np.float64] | None, str]:
        """``length_mm`` [mm] from the deviations.

        Parameters
        ----------
        m : Measurement
            The measurement.
        """
        from volcal.session.multilateration import length_from_deviation

        values = m.deviation
        if values is not None:
            values = length_from_deviation(values, m.positions, m.tool_offset,
                                           m.meta["station_mm"])
        return self.value_column, values, "{:.8f}"

    def exact(self, machine: Any, m: Any, setup: Any = None) -> NDArray[np.float64]:
        """Exact deviations [um] at the station of the set-up (default: as planned).

        Parameters
        ----------
        machine : MachineErrors
            The (virtual) machine.
        m : Measurement
            The measurement.
        setup : object, optional
            Set-up errors drawn by :meth:`simulate`; None: a perfect set-up.
        """
        from volcal.measure.multilateration import length_exact, station_of
        from volcal.session.multilateration import deviation_from_length

        station = getattr(setup, "station_mm", None)
        L = length_exact(machine, m, station)
        return deviation_from_length(L, m.positions, m.tool_offset, station_of(m))

    def rows(self, chain_order: Any, nodes: Any, m: Any, *, drift: bool = False,
             tilts: bool = True) -> RowBlock:
        """Rows with the shared station nuisances (:mod:`volcal.identify.multilateration`).

        Parameters
        ----------
        chain_order : sequence of int
            ``Chain.order``.
        nodes : list of 3 arrays
            Node positions per axis [mm].
        m : Measurement
            The measurement.
        drift : bool
            Add a drift nuisance where it is separable from the geometry.
        tilts : bool
            Add the set-up tilt nuisances where the kind has them.
        """
        from volcal.identify.multilateration import row_block

        return RowBlock(*row_block(chain_order, nodes, m, drift))

    def nuisance_priors(self, m: Any) -> dict[str, tuple[float, float]]:
        """The station placed to ``station_u_mm``.

        Parameters
        ----------
        m : Measurement
            The measurement.
        """
        from volcal.identify.multilateration import station_priors

        return station_priors(m)

    def advise_notes(self, session: Any, planned: Any, options: Any) -> list[str]:
        """The tracker's design notes and, with ``suggest``, its layouts compared.

        Parameters
        ----------
        session : Session
            The planned session.
        planned : Session
            Its copy with zero readings.
        options : IdentifyOptions
            The options of ``advise``.

        Returns
        -------
        list of str
        """
        from volcal.identify import multilateration as _ml

        out = list(_ml.design_notes(session))
        if options.suggest:
            out += _ml.layout_messages(_ml.compare_layouts(planned, options))
        return out

    def simulate(self, m: Any, machine: Any, rng: np.random.Generator, options: Any,
                 shared: dict[str, Any]) -> Any:
        """Simulated lengths (:func:`volcal.measure.multilateration.simulate_tracker`).

        Parameters
        ----------
        m : Measurement
            The measurement.
        machine : MachineErrors
            The (virtual) machine.
        rng : numpy.random.Generator
            The simulation's random generator.
        options : SimulationOptions
            Noise, misalignments, drift, dwell.
        shared : dict
            State shared by the measurements of one simulation.
        """
        from volcal.measure.multilateration import simulate_tracker

        return simulate_tracker(m, machine, rng, options.noise_um, options.dwell_s,
                                options.drift_um_per_h, shared.setdefault("stations", {}),
                                shared.get("tracker"))

    def plan(self, test: str, options: Any, only: str | None = None) -> list[Any]:
        """Stations and tool offsets over a grid (:mod:`volcal.plan.multilateration`).

        Parameters
        ----------
        test : str
            One of :attr:`plan_tests`.
        options : volcal.plan.planner.PlanOptions
            The plan's options.
        only : str or None
            Axis or plane qualifier (``linear:x``); None: all.
        """
        from volcal.plan.planner import _multilateration

        return _multilateration(options, only)

    def report_section(self, inp: Any) -> Any:
        """The multilateration section (:mod:`volcal.report.multilateration`).

        Parameters
        ----------
        inp : volcal.report.sections.ReportInputs
            The session and its results.
        """
        from volcal.report.multilateration import multilateration_section

        return multilateration_section(inp)


MULTILATERATION = register_kind(MultilaterationKind)
