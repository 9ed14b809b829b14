"""The direct optics: what the straightness and angular kinds share.

One error motion read at a time along a line (:mod:`volcal.session.optics` for the keys,
:mod:`volcal.measure.optics` for the forward model, :mod:`volcal.identify.optics` for the
rows and their reference nuisances, :mod:`volcal.standards.optics` for the evaluation,
:mod:`volcal.report.optics` for the report's section).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from volcal.session.kinds import Kind, ReadContext, RowBlock

__all__ = ["OpticKind", "read_optic_entry"]


def read_optic_entry(entry: dict[str, Any], ctx: ReadContext, column: str) -> Any:
    """A direct-optics measurement: its keys (:func:`volcal.session.optics.read_optic_keys`).

    Parameters
    ----------
    entry : dict
        The ``[[measurements]]`` entry.
    ctx : ReadContext
        Its checked keys and the session's context.
    column : str
        The reading column (``deviation_um`` or ``angle_urad``).

    Returns
    -------
    Measurement
    """
    from volcal.session.checks import check_travel
    from volcal.session.format import Measurement, missed_dropped, read_rows
    from volcal.session.optics import read_optic_keys

    r = read_rows(ctx.csv_path, column)
    check_travel(r.positions, r.rows, ctx.travel, ctx.csv_path)
    meta = read_optic_keys(ctx.kind, ctx.target, entry, r.positions, r.rows, ctx.where,
                           ctx.toml_path, ctx.csv_path, ctx.vertical)
    k = "xyz".index(meta["axis"])
    n = np.eye(3)[k] * (1.0 if r.positions[:, k].max() - r.positions[0, k]
                        >= r.positions[0, k] - r.positions[:, k].min() else -1.0)
    r = missed_dropped(r, meta, ctx)
    return Measurement(ctx.id, ctx.kind, ctx.target, r.positions, r.deviation, n,
                       ctx.tool_offset, ctx.file, r.columns, meta, r.rows)


class OpticKind(Kind):
    """A direct optic read along one axis (straightness or angular)."""

    beam_in_session: ClassVar[bool] = False
    standard: ClassVar[str | None] = "ISO 230-1"
    systematic: ClassVar[str | None] = "optic"

    def read(self, entry: dict[str, Any], ctx: ReadContext) -> Any:
        """Read the entry, its optic's keys and its CSV.

        Parameters
        ----------
        entry : dict
            The ``[[measurements]]`` entry as parsed.
        ctx : ReadContext
            Its checked keys and the session's context.
        """
        return read_optic_entry(entry, ctx, self.value_column)

    def axis(self, m: Any) -> int | None:
        """The ``axis`` key, else the axis that moves most.

        Parameters
        ----------
        m : Measurement
            The measurement.
        """
        a = m.meta.get("axis")
        if isinstance(a, str) and a.lower() in ("x", "y", "z"):
            return "xyz".index(a.lower())
        return int(np.argmax(np.ptp(m.positions, axis=0)))

    def exact(self, machine: Any, m: Any, setup: Any = None,
              q_actual: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """Exact readings [um or urad] (:func:`volcal.measure.optics.optic_exact`).

        Parameters
        ----------
        machine : MachineErrors
            The (virtual) machine.
        m : Measurement
            The measurement.
        setup : object, optional
            Set-up errors drawn by :meth:`simulate`; None: a perfect set-up.
        q_actual : ndarray, shape (n, 3), optional
            Axis positions actually reached [mm]; default the commanded ones.
        """
        from volcal.measure.optics import optic_exact

        return optic_exact(machine, m, setup, q_actual)

    def rows(self, chain_order: Any, nodes: Any, m: Any, *, drift: bool = False,
             tilts: bool = True) -> RowBlock:
        """Weighted rows with the offset and reference nuisances.

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
        from volcal.identify.optics import row_block

        return RowBlock(*row_block(chain_order, nodes, m, drift))

    def row_weight(self, m: Any) -> float:
        """The optic's weight (:func:`volcal.measure.optics.row_weight`).

        Parameters
        ----------
        m : Measurement
            The measurement.
        """
        from volcal.measure.optics import row_weight

        return float(row_weight(m))

    def design_notes(self, measurements: list[Any]) -> list[str]:
        """What each direct optic adds (:func:`volcal.identify.optics.optics_notes`).

        Parameters
        ----------
        measurements : list of Measurement
            The measurements (of every kind) of the design.
        """
        from volcal.identify.optics import optics_notes

        return optics_notes(measurements)

    def prepare(self, session: Any) -> None:
        """Group the lines of one reference (:func:`~volcal.session.optics.annotate_references`).

        Parameters
        ----------
        session : Session
            The session (modified in place).
        """
        from volcal.session.optics import annotate_references

        annotate_references(session.measurements, session.references)

    def simulate(self, m: Any, machine: Any, rng: np.random.Generator, options: Any,
                 shared: dict[str, Any]) -> Any:
        """Simulated readings (:func:`volcal.measure.optics_simulate.simulate_optic`).

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
        from volcal.measure.optics_simulate import simulate_optic

        return simulate_optic(m, machine, rng, options.noise_um, options.dwell_s,
                              options.drift_um_per_h, options.reversal,
                              shared.setdefault("optics", {}))

    def program_setup_lines(self, m: Any) -> list[str] | None:
        """Which optic, how set up (:func:`volcal.program.optics.optic_setup_lines`).

        Parameters
        ----------
        m : Measurement
            The measurement.
        """
        from volcal.program.optics import optic_setup_lines

        return optic_setup_lines(m)

    def report_section(self, inp: Any) -> Any:
        """The direct optics' section (:func:`volcal.report.optics.optics_section`).

        Parameters
        ----------
        inp : volcal.report.sections.ReportInputs
            The session and its results.
        """
        from volcal.report.optics import optics_section

        return optics_section(inp)
