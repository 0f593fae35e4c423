"""``python -m vrcal`` runs the command-line interface."""

from vrcal.cli import main

if __name__ == "__main__":  # pragma: no cover
    main()
