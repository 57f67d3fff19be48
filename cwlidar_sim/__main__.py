"""``python -m cwlidar_sim``: the ``cwlidar-sim`` command line (:mod:`cwlidar_sim.cli`)."""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
