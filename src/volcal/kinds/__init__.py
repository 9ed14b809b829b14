"""Measurement kinds as plug-ins.

One module per built-in kind (:mod:`volcal.kinds.linear`, ``diagonal``,
``step_diagonal``, ``multilateration``, ``straightness``, ``angular``, ``rotary``,
``probe_sphere``, ``r_test``; the shared parts in :mod:`volcal.kinds.laser`,
:mod:`volcal.kinds.optics` and :mod:`volcal.kinds.outside_design`) and the registry's
API, which lives low beside the session format (:mod:`volcal.session.kinds`) so that
every room can look a kind up (``docs/architecture.md``, "Adding a measurement kind").
"""

from volcal.session.kinds import (
    BUILTIN_KINDS,
    Kind,
    ReadContext,
    RowBlock,
    hooks_of,
    kind_names,
    kind_of,
    kinds,
    register_kind,
    target_names,
    unregister_kind,
)

__all__ = ["BUILTIN_KINDS", "Kind", "ReadContext", "RowBlock", "hooks_of", "kind_names",
           "kind_of", "kinds", "register_kind", "target_names", "unregister_kind"]
