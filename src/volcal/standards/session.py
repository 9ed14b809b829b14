"""Evaluate a whole session to the standards: one definition of every index.

:func:`evaluate_session` is the single place where a session is evaluated: ISO 230-2 for
every linear test with runs and directions, ISO 230-6 for every diagonal, and, given an
identified model, the ISO 230-1 volumetric indices. The command line (``volcal evaluate
session``), the report and :class:`volcal.Calibration` all call it.

ELv (seed 002, Wang) is ``sqrt(ELx^2 + ELy^2 + ELz^2)`` with ``ELx = max Dx(x) - min Dx(x)``
the range of the positioning error of X over its travel (and likewise Y, Z). Measured,
``Dx(x)`` is the mean bidirectional positional deviation at each target, so ``ELx`` is
ISO 230-2's ``M`` of the axis' linear test (the first one of the session on that axis,
the planned on-axis line); when some axis has no such test and a model is given, all
three ranges come from the model's ``EXX``, ``EYY``, ``EZZ`` over the travel. Either way
it is the same quantity, and :attr:`SessionEvaluation.elv_source` says which data gave it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from volcal.standards.iso230_6 import elv as _elv

if TYPE_CHECKING:
    import pandas

__all__ = ["SessionEvaluation", "evaluate_session"]


@dataclass
class SessionEvaluation:
    """Indices of a session.

    Attributes
    ----------
    iso230_2 : dict of str to ISO 230-2 result
        Per linear measurement id (A, E, M, R, B, mean reversal [um]...).
    axis : dict of str to str
        Moving axis of each evaluated linear measurement.
    iso230_6 : dict of str to ISO 230-6 result
        Per diagonal measurement id.
    volumetric : VolumetricIndices or None
        ISO 230-1 volumetric indices of the model [um] (given a model).
    elv : dict of str to float or None
        ``ELx``, ``ELy``, ``ELz``, ``ELv`` [um] (seed 002); ``None`` when neither the
        measured lines nor a model cover the three axes.
    elv_source : str
        ``'measured'`` (ISO 230-2 ``M`` of each axis' first linear test), ``'model'``
        (ranges of EXX, EYY, EZZ) or ``''``.
    skipped : dict of str to str
        Measurements not evaluated, with the reason.
    unmeasured : list of str
        Planned measurements without readings (``Session.unmeasured``).
    """

    iso230_2: dict[str, Any] = field(default_factory=dict)
    axis: dict[str, str] = field(default_factory=dict)
    iso230_6: dict[str, Any] = field(default_factory=dict)
    volumetric: Any = None
    elv: dict[str, float] | None = None
    elv_source: str = ""
    skipped: dict[str, str] = field(default_factory=dict)
    unmeasured: list[str] = field(default_factory=list)

    @property
    def model_indices(self) -> dict[str, Any] | None:
        """Straightness [um] and squareness [urad] of the model with U, JSON-friendly.

        ``{'straightness': {name: {'value_um', 'U_um', ...}}, 'squareness': {name:
        {'value_urad', 'U_urad', ...}}}``; None without a model uncertainty.
        """
        u = getattr(self.volumetric, "uncertainty", None)
        if u is None:
            return None
        return {"straightness": {k: {"value_um": v.value, "U_um": v.U, "u_um": v.u,
                                     "u_noise_um": v.u_noise, "u_sys_um": v.u_sys,
                                     "k": v.k, "reference": "least_squares"}
                                 for k, v in u.straightness.items()},
                "squareness": {k: {"value_urad": v.value, "U_urad": v.U, "u_urad": v.u,
                                   "u_noise_urad": v.u_noise, "u_sys_urad": v.u_sys,
                                   "k": v.k} for k, v in u.squareness.items()}}

    @property
    def incomplete(self) -> list[str]:
        """Ids of the evaluated tests with missed readings (linear and diagonal)."""
        return [k for k, v in [*self.iso230_2.items(), *self.iso230_6.items()]
                if not getattr(v, "complete", True)]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (values [um])."""
        return {"measurements": {k: {"axis": self.axis[k], **v.to_dict()}
                                 for k, v in self.iso230_2.items()},
                "diagonals": {k: _plain(v) for k, v in self.iso230_6.items()},
                "volumetric": None if self.volumetric is None else self.volumetric.to_dict(),
                **({} if self.model_indices is None else self.model_indices),
                "ELv": None if self.elv is None else self.elv["ELv"],
                "elv": self.elv, "elv_source": self.elv_source,
                "skipped": list(self.skipped), "incomplete": self.incomplete,
                "unmeasured": list(self.unmeasured)}

    def to_rows(self, table: str = "iso230-2") -> list[dict[str, Any]]:
        """One table of the evaluation, one row per measurement.

        Parameters
        ----------
        table : str
            ``'iso230-2'`` (linear tests: ``id``, ``axis``, ``A_um`` ... ``B_mean_um``
            [um]) or ``'iso230-6'`` (diagonals: ``id``, ``diagonal``, ``length_mm``,
            ``E_D_um`` ...); see :func:`volcal.io.frames.session_rows`.

        Returns
        -------
        list of dict
        """
        from volcal.io.frames import session_rows

        return session_rows(self, table)

    def to_dataframe(self, table: str = "iso230-2") -> pandas.DataFrame:
        """:meth:`to_rows` as a pandas DataFrame (needs pandas).

        Parameters
        ----------
        table : str
            ``'iso230-2'`` or ``'iso230-6'``.

        Returns
        -------
        pandas.DataFrame
        """
        from volcal.io.frames import to_dataframe

        return to_dataframe(self.to_rows(table), "SessionEvaluation")

    def __repr__(self) -> str:
        """Short one-line description."""
        ev = "None" if self.elv is None else f"{self.elv['ELv']:.3f} um ({self.elv_source})"
        return (f"SessionEvaluation({len(self.iso230_2)} linear, {len(self.iso230_6)} "
                f"diagonal, ELv={ev}, skipped={len(self.skipped)})")


def _plain(v: Any) -> Any:
    if hasattr(v, "to_dict"):
        return v.to_dict()
    from dataclasses import asdict, is_dataclass

    if is_dataclass(v):
        import numpy as np

        return {k: (x.tolist() if isinstance(x, np.ndarray) else x)
                for k, x in asdict(v).items()}
    return v


def evaluate_session(session: Any, result: Any = None, edition: str = "2014",
                     model_uncertainty: bool = False) -> SessionEvaluation:
    """Evaluate every test of a session to its standard (one definition of every index).

    Parameters
    ----------
    session : Session
        The session (measurements without readings are skipped and listed).
    result : IdentificationResult, optional
        Identified model: adds the volumetric indices and the model's ELv when the
        measured lines do not cover the three axes.
    edition : str
        ISO 230-2 edition (``'2014'``, ``'2006'``, ``'1997'``).
    model_uncertainty : bool
        With ``result``: the expanded uncertainty of the volumetric indices (``U_E_VX``
        ... in ``volumetric.to_dict()``), of the straightness and squareness of the model
        (:attr:`SessionEvaluation.model_indices`) from the model's covariance, noise and
        systematic parts (:mod:`volcal.standards.model_uncertainty`; about a second).

    Returns
    -------
    SessionEvaluation

    Notes
    -----
    A linear test with missed captures is evaluated per target over the runs that reached
    it and marked incomplete (``complete``, ``missing``, ``notes`` of its result); an
    incomplete diagonal is marked likewise (:mod:`volcal.standards.iso230_6`). A test with
    too few captures left for any evaluation (e.g. one run in a direction) is listed in
    ``skipped`` with the reason, and the others are evaluated.

    ELv = sqrt(ELx^2 + ELy^2 + ELz^2), ELx = max Dx(x) - min Dx(x) (seed 002); see the
    module docstring for the measured and model sources.

    References
    ----------
    ISO 230-2:2014, Test code for machine tools, part 2: positioning accuracy.
    ISO 230-6:2002, diagonal displacement tests. ISO 230-1:2012, Annex (volumetric
    indices). Seed 002 (ELv).
    """
    from volcal.errors import VolcalInputError
    from volcal.session.kinds import kind_of
    from volcal.standards.iso230_2 import evaluate
    from volcal.standards.iso230_6 import evaluate_diagonal
    from volcal.standards.positioning_data import from_measurement

    ev = SessionEvaluation(unmeasured=[m.id for m in getattr(session, "unmeasured", [])])
    for m in session.measurements:
        if m.deviation is None:
            ev.skipped[m.id] = "no readings yet"
            continue
        standard = kind_of(m.kind).standard  # which standard evaluates it (volcal.kinds)
        if standard == "ISO 230-2":
            if "run" not in m.columns or "direction" not in m.columns:
                ev.skipped[m.id] = "no run/direction columns"
                continue
            d = from_measurement(m, session.path)
            try:
                ev.iso230_2[m.id] = evaluate(d.targets_mm, d.run, d.direction,
                                             d.deviation_um, edition, **d.evaluate_kwargs())
            except VolcalInputError as exc:
                if not m.meta.get("_missed"):
                    raise
                ev.skipped[m.id] = f"too many missed captures: {exc.message}"
                continue
            ev.axis[m.id] = d.axis or "?"
        elif standard == "ISO 230-6":
            try:
                ev.iso230_6[m.id] = evaluate_diagonal(m, edition)
            except VolcalInputError as exc:
                if not m.meta.get("_missed"):
                    raise
                ev.skipped[m.id] = f"too many missed captures: {exc.message}"
    first: dict[str, float] = {}
    for mid, r in ev.iso230_2.items():
        first.setdefault(ev.axis[mid], float(r.M))
    if all(a in first for a in "XYZ"):
        ev.elv = {"ELx": first["X"], "ELy": first["Y"], "ELz": first["Z"]}
        ev.elv["ELv"] = _elv(first["X"], first["Y"], first["Z"])
        ev.elv_source = "measured"
    if result is not None:
        from volcal.standards.volumetric import elv_from_model, volumetric_indices

        ev.volumetric = volumetric_indices(result.errors)
        if model_uncertainty:
            from volcal.standards.model_uncertainty import model_uncertainty as _mu

            ev.volumetric.uncertainty = _mu(result, n=ev.volumetric.n)
        if ev.elv is None:
            ev.elv = elv_from_model(result.errors)
            ev.elv_source = "model"
    return ev
