"""``python -m ffsm_pin.sim``: see :mod:`ffsm_pin.sim.cli`."""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
