"""Import of other lasers' exports into session measurements.

``units`` detects and converts length units; ``laser_csv`` reads a CSV export with a
column mapping (one reading per row, or ``wide``: one column per run) and adds it to a
session as a linear measurement; ``planned`` fills a planned linear, diagonal or
step-diagonal measurement with the readings of an export. Vendor binary formats
(Renishaw ``.rtl``, API, Keysight/Agilent ``.dat`` projects) are not publicly documented
and are not read: export CSV from the vendor software instead.
"""

from volcal.importer.laser_csv import ImportResult, import_csv, parse_mapping, read_laser_csv
from volcal.importer.planned import import_planned

__all__ = ["ImportResult", "import_csv", "import_planned", "parse_mapping", "read_laser_csv"]
