"""Exceptions raised for user mistakes.

Every error caused by bad input (a file, a CLI argument) is a :class:`VolcalInputError`
that names the file, the row and the column where possible; the CLI prints it without
a traceback.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
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


_PARAMETER = re.compile(r"\{([a-z_][a-z0-9_]*)(=?)(True)?\}")


class ParameterError(VolcalInputError):
    """A wrong value of a parameter of a step function (:mod:`volcal.steps`).

    The message names the parameters as placeholders, spelled by each face:
    ``{noise_um}`` is ``noise_um`` in Python and ``--noise-um`` on the command line;
    ``{noise_um=}`` (followed by the value) is ``noise_um=`` in Python and ``--noise-um ``
    on the command line; ``{force=True}`` is ``force=True`` in Python and ``--force`` on
    the command line (a flag). ``str()`` and :attr:`message` are the Python spelling; the command
    line respells the error with its table of options (:meth:`spelled`).

    Parameters
    ----------
    template : str
        The message with its placeholders, e.g. ``'{noise_um=}-1.0: expected a positive
        repeatability [um]'``.
    file, row, column
        As :class:`VolcalInputError`.

    Attributes
    ----------
    template : str
    parameters : tuple of str
        The parameters the message names, in order.
    """

    def __init__(self, template: str, file: str | Path | None = None, row: int | None = None,
                 column: str | None = None) -> None:
        self.template = template
        self.parameters = tuple(dict.fromkeys(m.group(1)
                                              for m in _PARAMETER.finditer(template)))
        super().__init__(spell(template, {}), file, row, column)

    def spelled(self, options: Mapping[str, str], where: str = "") -> VolcalInputError:
        """The same error with the parameters spelled as another face names them.

        Parameters
        ----------
        options : mapping of str to str
            Parameter -> its name on that face (``{'noise_um': '--noise-um'}``); a name
            starting with ``-`` is an option (``{x=}`` becomes ``--x `` with a space).
            A parameter not in the mapping keeps its Python name.
        where : str
            Put before the message (``'Calibration.identify: '``).

        Returns
        -------
        VolcalInputError
            A plain error (no placeholders left), same file, row and column.
        """
        return VolcalInputError(where + spell(self.template, options), self.file, self.row,
                                self.column)


def spell(template: str, options: Mapping[str, str]) -> str:
    """A message of :class:`ParameterError` with its placeholders spelled.

    Parameters
    ----------
    template : str
        Message with ``{name}``, ``{name=}`` and ``{name=True}`` placeholders.
    options : mapping of str to str
        Parameter -> name on the face; missing: the Python name.

    Returns
    -------
    str
    """
    def one(m: re.Match[str]) -> str:
        name, eq, flag = m.group(1), m.group(2), m.group(3)
        shown = options.get(name, name)
        if flag:  # a flag: --force, force=True
            return shown if shown.startswith("-") else f"{shown}={flag}"
        if not eq:
            return shown
        return shown + " " if shown.startswith("-") else shown + "="

    return _PARAMETER.sub(one, template)
