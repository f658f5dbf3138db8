"""``python -m ffsm_pin.sweep``: see :mod:`ffsm_pin.sweep.cli`."""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
