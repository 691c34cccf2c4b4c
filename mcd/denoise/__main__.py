"""``python -m mcd.denoise``: see :mod:`mcd.denoise.cli`."""

from mcd.denoise.cli import main

if __name__ == "__main__":
    main()
