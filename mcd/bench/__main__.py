"""``python -m mcd.bench [MODE] [ARGS]``: the measuring commands behind one name (docs/benchmark.md "Metrics",
speed; docs/training.md "Throughput"). Each mode is a module of :mod:`mcd.bench`, imported only when
chosen, and ``python -m mcd.bench MODE --help`` shows that module's own options.

The mode is the first argument; without one (nothing, or an option or override first) the command measures
inference speed (``speed``). A first word that names no mode is refused, listing the modes.
"""

from __future__ import annotations

import argparse
import importlib
import sys

#: mode -> (module whose ``main(argv)`` runs it, one line of help). ``speed`` is the default.
MODES: dict[str, tuple[str, str]] = {
    "speed": ("mcd.bench.speed", "inference ms/frame of every method (the default mode)"),
    "train": ("mcd.bench.train", "training steps/s of each method and training path"),
    "profile": ("mcd.bench.profile", "where a two-stage row's inference time goes, stage by stage"),
    "loader": ("mcd.bench.loader", "training clips/s of one loader worker, EXR vs the training store"),
}
DEFAULT = "speed"


def parser() -> argparse.ArgumentParser:
    """The top-level parser: one sub-command per mode; everything after the mode goes to that mode's tool."""
    top = argparse.ArgumentParser(prog="python -m mcd.bench",
                                  description="The measuring commands: choose a mode; MODE --help shows its "
                                              "options.",
                                  epilog=f"Without a mode: {DEFAULT}.")
    modes = top.add_subparsers(dest="mode", metavar="MODE", title="modes")
    for name, (module, text) in MODES.items():
        modes.add_parser(name, help=f"{text} ({module})", add_help=False)
    return top


def main(argv: list[str] | None = None) -> None:
    """Choose the mode (first argument, or :data:`DEFAULT`) and run its tool."""
    args = list(sys.argv[1:] if argv is None else argv)
    if not args or (args[0] not in ("-h", "--help") and (args[0].startswith("-") or "=" in args[0])):
        args.insert(0, DEFAULT)  # a word that is no mode reaches the parser, which refuses it
    chosen = parser().parse_args(args[:1])
    importlib.import_module(MODES[chosen.mode][0]).main(args[1:])


if __name__ == "__main__":
    main()
