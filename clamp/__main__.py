"""``python -m clamp`` runs the command line (see :mod:`clamp.cli`)."""
import sys

from clamp.cli import main

sys.exit(main())
