"""``python -m volcal``: the ``volcal`` command (:func:`volcal.cli.main`)."""

from volcal.cli import main

main()
