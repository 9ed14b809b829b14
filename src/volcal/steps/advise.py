"""Step ``advise``: before measuring, what the planned tests will determine."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from volcal import defaults as D
from volcal.errors import ParameterError

if TYPE_CHECKING:
    from volcal.identify import EstimatorSettings
    from volcal.identify.identifiability import IdentifiabilityReport
    from volcal.identify.location_advice import PoseRanking
    from volcal.session.format import Session

__all__ = ["Advice", "advise", "rank_poses"]


@dataclass(frozen=True)
class Advice:
    """What :func:`advise` found.

    Attributes
    ----------
    report : IdentifiabilityReport
        ``.messages`` in plain words, ``.suggestions``, ``.ambiguity_um`` [um]; for a
        session of probe_sphere tests only, the location errors' messages (no linear
        figures: ``n_parameters`` 0, ``ambiguity_um`` NaN).
    locations : tuple of PoseRanking
        For each 5-axis chain of the session's probe_sphere tests, the candidate poses
        and sphere positions ranked by what they add to the location errors (empty
        without such tests).
    """

    report: IdentifiabilityReport
    locations: tuple[PoseRanking, ...] = field(default_factory=tuple)

    @property
    def messages(self) -> list[str]:
        """The report's messages, in plain words."""
        return list(self.report.messages)

    def to_dict(self) -> dict[str, Any]:
        """The document of ``volcal advise --json`` (NaN, a figure there is none of: null)."""
        between = getattr(self.report, "between", None)
        return _plain({"format": "volcal-advice/1", "messages": self.messages,
                       "identifiability": self.report.to_dict(),
                       "between_readings": None if between is None else between.to_dict(),
                       "location_candidates": [r.to_dict() for r in self.locations]})


def _plain(v: Any) -> Any:
    """JSON-ready: numpy numbers as Python's, NaN as None."""
    import math

    import numpy as np

    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, list | tuple | np.ndarray):
        return [_plain(x) for x in v]
    if isinstance(v, bool | np.bool_):
        return bool(v)
    if isinstance(v, int | np.integer):
        return int(v)
    if isinstance(v, float | np.floating):
        return None if math.isnan(float(v)) else float(v)
    return v


def _probe_tests(session: Session) -> list[Any]:
    return [m for m in list(session.measurements) + list(session.unmeasured)
            if m.kind == "probe_sphere"]


def rank_poses(session: Session, *, candidates: str | Path | None = None,
               top: int = D.ADVISE_TOP) -> list[PoseRanking]:
    """Candidate poses and sphere positions ranked for each chain's probe_sphere tests.

    Parameters
    ----------
    session : Session
        The (planned) session; its probe_sphere tests' poses are the design (their
        readings are not used), its ``[[machine.rotary_axes]]`` ranges bound the
        generated candidates.
    candidates : str or Path, optional
        A CSV of candidates (:func:`volcal.identify.location_advice.read_candidates`);
        default the generated set (:func:`~volcal.identify.location_advice.default_candidates`).
    top : int
        How many candidates to keep per chain.

    Returns
    -------
    list of PoseRanking
        One per chain (empty without probe_sphere tests).
    """
    from volcal.identify.location_advice import rank_candidates, read_candidates
    from volcal.kinds.probe_sphere import five_axis_machine, sphere_readings

    ms = _probe_tests(session)
    ranges = {}
    for ax in session.meta.get("rotary_axes") or []:
        name = getattr(ax, "name", None) or (ax.get("name") if isinstance(ax, dict) else None)
        rng = getattr(ax, "range_deg", None) or (ax.get("range_deg") if isinstance(ax, dict)
                                                 else None)
        if name and rng:
            ranges[str(name).upper()] = (float(rng[0]), float(rng[1]))
    out = []
    for chain in dict.fromkeys(m.meta["chain"] for m in ms):
        group = [m for m in ms if m.meta["chain"] == chain]
        nominal = five_axis_machine(group[0])
        blocks = [sphere_readings(m, nominal_centres=True) for m in group]
        cands = None if candidates is None else read_candidates(candidates, nominal, blocks)
        out.append(rank_candidates(nominal, blocks, cands, top=top,
                                   measurements=[m.id for m in group],
                                   source="generated" if candidates is None
                                   else Path(candidates).name, ranges=ranges))
    return out


def _location_only(session: Session) -> IdentifiabilityReport:
    """The report of a session without linear tests: the probe_sphere kind's notes."""
    from volcal.identify.identifiability import IdentifiabilityReport
    from volcal.session.kinds import hooks_of

    rep = IdentifiabilityReport(0, 0, 0, {}, float("nan"), float("nan"))
    rep.messages.append("No linear test: the analysis is of the rotary axes' location errors "
                        "(probe_sphere tests) only.")
    kinds = [m.kind for m in list(session.measurements) + list(session.unmeasured)]
    for notes in hooks_of(list(dict.fromkeys(kinds)), "advise_notes"):
        rep.messages += notes(session, session, None)
    return rep


def advise(session: Session | str | Path, *, roll: str = D.ROLL,
           candidates: str | Path | None = None, top: int = D.ADVISE_TOP,
           settings: EstimatorSettings | str | Path | None = None,
           **options: Any) -> Advice:
    """What the planned tests will and will not determine (the readings are not used).

    Parameters
    ----------
    session : Session, str or Path
        A planned (or measured) session, or its folder; every measurement counts, those
        without readings included.
    roll : str
        ``'estimate'`` or ``'zero'`` (the rolls EAX, EBY, ECZ fixed to zero).
    candidates : str or Path, optional
        With probe_sphere tests: a CSV of candidate poses and sphere positions to rank
        (``docs/fiveaxis.md``); default a generated set.
    top : int
        With probe_sphere tests: how many ranked candidates to list per chain.
    settings : EstimatorSettings, str or Path, optional
        The estimator's settings (its ``typical_scales`` are the prior of the advice), or
        the path of an estimator settings file (TOML, as ``--estimator-settings``);
        default volcal's.
    **options
        Other fields of :class:`volcal.identify.IdentifyOptions` (``known`` as a dict
        or a path, with ``known_u``...), checked as by :func:`volcal.steps.identify.identify`.

    Returns
    -------
    Advice
    """
    from volcal.identify import advise as run
    from volcal.steps.identify import _read_known, identify_options

    if isinstance(top, bool) or not isinstance(top, int) or top < 1:
        raise ParameterError(f"{{top=}}{top}: expected a whole number of candidates >= 1")
    opts, known_file = identify_options(("known_u",), roll=roll, settings=settings,
                                        **options)
    if isinstance(session, str | Path):
        from volcal.session.format import read_session

        session = read_session(session, require_deviation=False)
    if known_file is not None:
        opts = _read_known(opts, known_file, options.get("known_u"))
    probes = _probe_tests(session)
    if candidates is not None and not probes:
        raise ParameterError(f"{{candidates=}}{candidates}: the session has no probe_sphere "
                             "test to rank candidate poses for")
    if candidates is not None and not Path(candidates).is_file():
        raise ParameterError(f"{{candidates=}}{candidates}: no such file")
    from volcal.session.kinds import kind_of

    linear = any(kind_of(m.kind).in_design
                 for m in list(session.measurements) + list(session.unmeasured))
    if not probes:
        _refuse_without_linear_tests(session)  # rotary or R-test tests alone
    report = run(session, opts) if linear else _location_only(session)
    ranked = tuple(rank_poses(session, candidates=candidates, top=top)) if probes else ()
    for r in ranked:
        report.messages.extend(r.lines())
    return Advice(report, ranked)


def _refuse_without_linear_tests(session: Session) -> None:
    """Refuse a session none of whose tests enters the linear identification.

    advise ranks what the tests determine of the linear axes' model (``volcal identify``);
    a rotary test is evaluated on its own (ISO 230-2 for rotary axes), R-test tests locate
    the rotary axes: with only those there is nothing to rank, which is said plainly here
    rather than by the identification's "no measurements selected". (A session with
    probe_sphere tests is advised on their poses, :func:`rank_poses`, and not refused.)
    """
    from volcal.errors import VolcalInputError
    from volcal.session.kinds import kind_of

    if any(kind_of(m.kind).in_design for m in session.measurements):
        return
    kinds = sorted({m.kind for m in session.measurements})
    name = str(session.path) if session.path is not None else session.name
    why = ["advise ranks the tests for the identification of the linear axes (the model of "
           f"volcal identify), and session {name} has none (its tests: "
           + (", ".join(f"{m.id} ({m.kind})" for m in session.measurements) or "none") + ")"]
    if "rotary" in kinds:
        why.append("the rotary axes are evaluated by ISO 230-2 alone: volcal evaluate "
                   f"session {name}, or volcal evaluate iso230-2 FILE per test")
    located = [k for k in ("probe_sphere", "r_test") if k in kinds]
    if located:
        why.append(f"{' and '.join(located)} tests locate the rotary axes: volcal locate")
    raise VolcalInputError("; ".join(why),
                           None if session.path is None else session.path / "session.toml")
