"""Exceptions raised for user mistakes.

Every error caused by bad input (a file, a CLI argument) is a :class:`VolcalInputError`
that names the file, the row and the column where possible; the CLI prints it without
a traceback.
"""

from __future__ import annotations

from pathlib import Path


class VolcalInputError(ValueError):
    """Bad user input, located as precisely as possible.

    Parameters
    ----------
    message : str
        What is wrong, in plain words.
    file : str or Path, optional
        File in which the problem was found.
    row : int, optional
        1-based row number in the file (the CSV header is row 1).
    column : str, optional
        Column name or TOML key.
    """

    def __init__(
        self,
        message: str,
        file: str | Path | None = None,
        row: int | None = None,
        column: str | None = None,
    ) -> None:
        self.message = message
        self.file = None if file is None else str(file)
        self.row = row
        self.column = column
        super().__init__(self.__str__())

    def __str__(self) -> str:
        where = []
        if self.file is not None:
            where.append(self.file)
        if self.row is not None:
            where.append(f"row {self.row}")
        if self.column is not None:
            where.append(f"column '{self.column}'")
        return (", ".join(where) + ": " if where else "") + self.message
