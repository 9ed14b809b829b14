"""Part programs that move a machine through the planned poses of a session.

``steps`` turns a measurement into dialect-free steps (moves, dwells, comments), with
ISO 230-2 approach and overrun moves for linear tests; ``dialects`` renders them as
Fanuc/ISO or LinuxCNC G-code, Siemens 840D or Heidenhain conversational programs; ``writer``
writes one program per measurement into a folder, atomically.
"""

from volcal.program.dialects import DIALECTS, render
from volcal.program.steps import ProgramOptions, Step, build_steps
from volcal.program.writer import write_programs

__all__ = ["DIALECTS", "ProgramOptions", "Step", "build_steps", "render", "write_programs"]
