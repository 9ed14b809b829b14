"""Honesty of the history's change test (docs/history.md): false alarms and power.

Pairs of simulated calibrations (the seeds' full set on 800 x 600 x 500 mm, XYFZ, 10
increments, 0.5 um noise, independent set-ups and noise) of random machines:
unchanged; X scale +10 um/m; EC0Y +20 urad. Prints, per case, how many pairs flag
anything (family-wise false alarms, for the unchanged pairs) and how often the changed
function is flagged, and anything else flagged.

    .venv/bin/python benchmarks/history_study.py --machines 10
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
from pathlib import Path

TRAVEL = [[0, 800], [0, 600], [0, 500]]


def pair(tmp: Path, base, changed, seed: int):
    from volcal.flow import Calibration
    from volcal.history.api import History

    h = History(str(tmp / f"h{seed}.sqlite"))
    ids = []
    for i, m in enumerate((base, changed)):
        c = Calibration.plan(TRAVEL, steps=10)
        c.simulate(machine=m, seed=10 * seed + i)
        folder = tmp / f"S{seed}-{i}"
        c.save(folder)
        c.identify().to_json(folder / "model.json")
        ids.append(h.add(folder, folder / "model.json").id)
    df = h.compare(*ids)
    h.close()
    f = df[df.test == "chi-square"]
    return list(f.name[f.changed.fillna(False)])  # changed: pandas "boolean" (NA undecided)


def main() -> None:
    from volcal.measure.virtual import random_machine

    ap = argparse.ArgumentParser()
    ap.add_argument("--machines", type=int, default=10)
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="volcal-hstudy-"))
    cases = {"unchanged": None, "X scale +10 um/m": "EXX", "EC0Y +20 urad": "EC0Y"}
    try:
        for case, target in cases.items():
            any_flag = hit = other = 0
            for k in range(args.machines):
                base = random_machine(TRAVEL, "XYFZ", seed=500 + k)
                m = base.copy()
                if target == "EXX":
                    m.values[0][:, 0] += 0.010 * m.nodes[0]
                elif target == "EC0Y":
                    m.squareness[0] += 20.0
                flagged = pair(tmp, base, m, 1000 * len(case) + k)
                any_flag += bool(flagged)
                hit += target in flagged if target else 0
                other += any(f != target for f in flagged)
            n = args.machines
            if target is None:
                print(f"{case}: {any_flag} of {n} pairs flag a function (family-wise level 5 %)")
            else:
                print(f"{case}: {target} flagged in {hit} of {n} pairs; another function "
                      f"flagged in {other} of {n}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
