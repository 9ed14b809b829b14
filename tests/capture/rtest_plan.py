"""The default R-test plan cut to chosen poses, for the capture tests."""

from __future__ import annotations

from pathlib import Path


def plan_rtest(folder: Path, travel, poses) -> Path:
    """``volcal plan --tests r_test:ca`` into ``folder``, its CSV cut to ``poses``.

    Parameters
    ----------
    folder : Path
        The session folder to write.
    travel : sequence of 3 (min, max)
        The machine's travel [mm].
    poses : sequence of (c, a)
        The planned poses kept, in this order [deg].

    Returns
    -------
    Path
        ``folder``.
    """
    from volcal.steps.plan import plan

    plan(tuple(tuple(t) for t in travel), steps=2, tests="r_test:ca", output=folder)
    p = folder / "r_test.csv"
    rows = p.read_text().splitlines()
    keep = {(float(c), float(a)): r for r in rows[1:] for c, a in [r.split(",")[:2]]}
    p.write_text("\n".join([rows[0], *(keep[(float(c), float(a))] for c, a in poses)]) + "\n")
    return folder
