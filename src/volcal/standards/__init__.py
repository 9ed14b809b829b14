"""Evaluation to the standards: ISO 230-2, VDI/DGQ 3441, ISO 230-6, volumetric indices.

Modules
-------
iso230_2
    Positioning accuracy and repeatability of a linear axis.
vdi3441
    The VDI/DGQ 3441 positioning parameters (P, Pa, Ps, U).
iso230_6
    Body and face diagonal displacement tests; ELv.
volumetric
    ISO 230-1 volumetric indices from a machine model.
straightness
    Straightness of a line and squareness of two lines.
runs, positioning_data
    Validation and reading of positioning runs.
"""
