"""``python -m mcd.denoise``: see :mod:`mcd.denoise.cli`."""

import sys

from mcd.denoise.cli import main

if __name__ == "__main__":
    sys.exit(main())
