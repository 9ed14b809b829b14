"""The calibration report: HTML (self-contained) and PDF from one document model.

:mod:`volcal.report.document` defines the neutral document (sections of paragraphs,
warnings, tables and matplotlib figures); :mod:`volcal.report.sections` fills it from a
session and the results of the analysis; :mod:`volcal.report.html` and
:mod:`volcal.report.pdf` render it; :func:`volcal.report.writer.write_report` writes both
atomically. Only this package and :mod:`volcal.plot` import matplotlib.
"""

from volcal.report.document import FigureItem, Report, Section, Table
from volcal.report.writer import write_report

__all__ = ["FigureItem", "Report", "Section", "Table", "write_report"]
