import numpy as np
import pytest

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])


@pytest.fixture
def travel():
    return TRAVEL.copy()


def no_angles(machine, scale=0.0):
    """The machine with its angular errors multiplied by ``scale`` (0: removed)."""
    m = machine.copy()
    for v in m.values:
        v[:, 3:] *= scale
    return m
