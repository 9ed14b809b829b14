"""Which machine record a session belongs to: by serial when given, else name, chain, travel.

The rule is :func:`volcal.session.identity.same_machine`'s. A session that matches no
machine of the store adds one; a session that matches several is refused with the
candidates (two machines once recorded without serial and with equal name, chain and
travel, for example): the user names the machine with ``--machine ID``.
"""

from __future__ import annotations

from typing import Any

from volcal.errors import VolcalInputError
from volcal.session.identity import MachineIdentity, same_machine

#: Default calibration interval of a new machine [days] (ISO 230-2 gives none; 12 months
#: is the common practice of machine-tool builders and service companies).
DEFAULT_INTERVAL_DAYS = 365


def current_machines(records: list[Any]) -> list[Any]:
    """The newest record of each machine (superseded machine records left out).

    Parameters
    ----------
    records : list of Record
        Every record of the store.
    """
    return [r for r in records if r.kind == "machine" and r.superseded_by is None]


def match(records: list[Any], ident: MachineIdentity, machine_id: str | None = None) -> Any:
    """The machine record of an identity, or ``None`` when the store has none.

    Parameters
    ----------
    records : list of Record
        Every record of the store (``Store.records()``).
    ident : MachineIdentity
        The session's machine.
    machine_id : str, optional
        The user's choice (``--machine``): must be a machine record; its identity must
        agree.

    Raises
    ------
    VolcalInputError
        Ambiguous (the candidates are listed) or the chosen machine differs.
    """
    machines = current_machines(records)
    if machine_id is not None:
        chosen = [r for r in machines if r.id == machine_id or r.machine_name == machine_id]
        if len(chosen) != 1:
            raise VolcalInputError(f"--machine {machine_id}: no single current machine record "
                                   "of that id or name")
        ok, why = same_machine(MachineIdentity.from_dict(chosen[0].payload["machine"]), ident)
        if not ok:
            raise VolcalInputError(f"--machine {machine_id} is another machine: {why}")
        return chosen[0]
    found = [r for r in machines
             if same_machine(MachineIdentity.from_dict(r.payload["machine"]), ident)[0]]
    if len(found) > 1:
        cands = "; ".join(f"{r.id} {MachineIdentity.from_dict(r.payload['machine']).label()}"
                          for r in found)
        raise VolcalInputError(f"machine {ident.label()} matches {len(found)} machines of the "
                               f"history ({cands}): name one with --machine ID")
    return found[0] if found else None


def machine_payload(ident: MachineIdentity, interval_days: int = DEFAULT_INTERVAL_DAYS
                    ) -> dict[str, Any]:
    """Payload of a machine record.

    Parameters
    ----------
    ident : MachineIdentity
        The machine.
    interval_days : int
        Calibration interval [days].
    """
    return {"machine": ident.to_dict(), "interval_days": int(interval_days)}
