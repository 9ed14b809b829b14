"""Header lines of a part program for a direct-optics measurement: which optic, how set up.

``volcal program`` writes them into the comment header of each straightness or angular
program (``docs/formats.md``, "Direct optics").
"""

from __future__ import annotations

from volcal.session.format import Measurement

__all__ = ["optic_setup_lines"]


def _vec(v) -> str:
    return "[" + ", ".join(f"{float(x):g}" for x in v) + "]"


def optic_setup_lines(m: Measurement) -> list[str]:
    """Comment lines naming the optic of a straightness or angular measurement and its set-up.

    Parameters
    ----------
    m : Measurement
        A planned ``straightness`` or ``angular`` measurement.

    Returns
    -------
    list of str
        Empty for other kinds.
    """
    if m.kind not in ("straightness", "angular"):
        return []
    a = str(m.meta.get("axis", "?")).upper()
    if m.kind == "straightness":
        d = str(m.meta.get("error_direction", "?")).upper()
        out = [f"optic: straightness optics (straightness interferometer and reflector), "
               f"reads the displacement along +{d} while {a} moves"]
        if m.meta.get("sensor_position_mm") is not None:
            out.append("set-up: sensing optic fixed on the workpiece side at "
                       f"{_vec(m.meta['sensor_position_mm'])} mm, reference optic on the tool side")
        else:
            out.append(f"set-up: sensing optic on the tool at offset {_vec(m.tool_offset)} mm, "
                       "reference optic on the workpiece side")
        out.append(f"align the reference optic to the {a} motion (do not remove the slope)")
        ref = m.meta.get("reference")
        if ref:
            out.append(f"reference group {ref!r}: do not move the reference optic between the "
                       "lines of this group; a line across the group's first line is read "
                       "through the optical square")
        return out
    r = str(m.meta.get("rotation", "?")).upper()
    about = {"A": "X", "B": "Y", "C": "Z"}.get(r, "?")
    what = {"angular_optics": "angular optics (angular interferometer on the workpiece side, "
                              "angular reflector on the tool)",
            "level": "differential electronic level (one level on the tool side, the "
                     "reference level on the workpiece side)",
            "roll_optics": "roll channel of a 6-DOF laser (launch unit on the workpiece side, "
                           "receiver on the tool)"}.get(m.target, m.target)
    return [f"optic: {what}",
            f"reads the rotation about +{about} (E{r}{a}, right-hand rule) while {a} moves"]
