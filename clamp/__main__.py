"""``python -m clamp`` runs the command line (see :mod:`clamp.cli.main`)."""
import sys

from clamp.cli.main import main

sys.exit(main())
