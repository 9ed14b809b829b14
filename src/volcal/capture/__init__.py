"""Live capture: readings taken while the part program runs, one row per dwell.

The package sits below :mod:`volcal.steps` (the step :func:`volcal.steps.capture.capture`
drives it) and above the session and program rooms it reads. Its parts, one job each:

==================  =================================================================
module              what it holds
==================  =================================================================
``samples``         :class:`ControlSample`, :class:`LaserSample`, unit conversion
``sources``         the :class:`ControlSource` / :class:`LaserSource` protocols, the
                    source registry (``--control SOURCE``, ``--laser SOURCE``)
``frame``           the coordinates compared with the plan: X, Y, Z [mm], or a rotary
                    test's axis [deg] (modulo 360 on a full circle)
``plan``            the planned dwells of a measurement (targets, approach directions),
                    rebuilt from the same step list the part program was written from
                    (a rotary test: its program's turns)
``trigger``         the trigger rule (:class:`TriggerRule`, :class:`TriggerParams`): a
                    pure state machine fed samples, returning accepted points and missed
                    dwells
``journal``         the append-only journal (JSON lines, fsync) beside the session
``sessionfile``     the measurement CSV rewritten atomically as points are accepted
``runner``          the polling loop: sources -> rule -> journal -> CSV
``simulated``       a simulated control (timed motion of the planned program) and laser
                    (volcal's virtual machine)
``timeline``        the simulated control's timed program (moves, dwells, operator stop)
``virtual_rotary``  the rotary axis the simulated laser reads (``volcal simulate``'s)
``stream``          line-stream laser source (TCP, serial port, pipe) and its parser
``filetail``        laser readings appended to a file by a vendor program
``linuxcnc_source`` LinuxCNC control source through a bridge run by the system Python
==================  =================================================================

The method and the wiring are documented in ``docs/capture.md``.
"""

from volcal.capture.samples import ControlSample, LaserSample
from volcal.capture.sources import ControlSource, LaserSource

__all__ = ["ControlSample", "ControlSource", "LaserSample", "LaserSource"]
