"""Import of other lasers' exports into session measurements.

``units`` detects and converts length units; ``laser_csv`` reads a generic CSV export
with a column mapping and adds it to a session as a linear measurement. Vendor binary
formats (Renishaw ``.rtl``, API, Keysight/Agilent ``.dat`` projects) are not publicly
documented and are not read: export CSV from the vendor software instead.
"""

from volcal.importer.laser_csv import ImportResult, import_csv, parse_mapping, read_laser_csv

__all__ = ["ImportResult", "import_csv", "parse_mapping", "read_laser_csv"]
