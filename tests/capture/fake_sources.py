"""Sources the capture tests register to play a control or a laser that lacks something."""

from __future__ import annotations

from dataclasses import replace


class NoRotary:
    """The simulated control reporting the linear axes only (as an OPC UA server might)."""

    def __init__(self, spec, ctx):
        from volcal.capture.simulated import SimulatedControl

        self.inner = SimulatedControl(spec, ctx)

    def open(self):
        self.inner.open()

    def close(self):
        self.inner.close()

    def poll(self):
        s = self.inner.poll()
        if s is None:
            return None
        return replace(s, positions={a: v for a, v in s.positions.items() if a in "XYZ"})
