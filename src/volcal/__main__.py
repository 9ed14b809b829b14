"""``python -m volcal``: the ``volcal`` command (:func:`volcal.cli.main`)."""

from volcal.cli import main

if __name__ == "__main__":  # importing it (the tests walk every module) runs nothing
    main()
