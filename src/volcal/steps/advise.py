"""Step ``advise``: before measuring, what the planned tests will determine."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from volcal import defaults as D

if TYPE_CHECKING:
    from volcal.identify.identifiability import IdentifiabilityReport
    from volcal.session.format import Session

__all__ = ["Advice", "advise"]


@dataclass(frozen=True)
class Advice:
    """What :func:`advise` found.

    Attributes
    ----------
    report : IdentifiabilityReport
        ``.messages`` in plain words, ``.suggestions``, ``.ambiguity_um`` [um].
    """

    report: IdentifiabilityReport

    @property
    def messages(self) -> list[str]:
        """The report's messages, in plain words."""
        return list(self.report.messages)


def advise(session: Session | str | Path, *, roll: str = D.ROLL, **options: Any) -> Advice:
    """What the planned tests will and will not determine (the readings are not used).

    Parameters
    ----------
    session : Session, str or Path
        A planned (or measured) session, or its folder; every measurement counts, those
        without readings included.
    roll : str
        ``'estimate'`` or ``'zero'`` (the rolls EAX, EBY, ECZ fixed to zero).
    **options
        Other fields of :class:`volcal.identify.IdentifyOptions` (``known`` as a dict
        or a path, with ``known_u``...), checked as by :func:`volcal.steps.identify.identify`.

    Returns
    -------
    Advice
    """
    from volcal.identify import advise as run
    from volcal.steps.identify import _read_known, identify_options

    opts, known_file = identify_options(("known_u",), roll=roll, **options)
    if isinstance(session, str | Path):
        from volcal.session.format import read_session

        session = read_session(session, require_deviation=False)
    if known_file is not None:
        opts = _read_known(opts, known_file, options.get("known_u"))
    _refuse_without_linear_tests(session)
    return Advice(run(session, opts))


def _refuse_without_linear_tests(session: Session) -> None:
    """Refuse a session none of whose tests enters the linear identification.

    advise ranks what the tests determine of the linear axes' model (``volcal identify``);
    a rotary test is evaluated on its own (ISO 230-2 for rotary axes), probe-on-sphere and
    R-test tests locate the rotary axes: with only those there is nothing to rank, which is said
    plainly here rather than by the identification's "no measurements selected".
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
