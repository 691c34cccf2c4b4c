"""Checked command-line values of ``mcd-denoise`` and ``python -m mcd.denoise.render_frames``
(docs/denoise.md; docs/reliability.md, "Denoising your frames").

Every numeric option is parsed by one of these types, so a value out of its range is refused by argparse
itself, before anything is loaded, with the flag, the value and the range (``argument --width: 0 is not an
integer from 8 to 16384``). ``--scene`` must name a regular file: a folder, a device or a FIFO is named as
what it is. :class:`HelpFormatter` shows every option's default in ``--help``.
"""

from __future__ import annotations

import argparse
import math
import stat
from collections.abc import Callable
from pathlib import Path

#: Film sides accepted for rendering (at least the SSIM window, docs/benchmark.md).
MIN_SIDE, MAX_SIDE = 8, 16384


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """The description as written, and ``(default: ...)`` after the help of every option that has a default
    (not for flags, nor for options that are unset by default)."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if action.default not in (None, False, argparse.SUPPRESS) and action.option_strings:
            text += " (default: %(default)s)"
        return text


def int_in(lo: int, hi: int) -> Callable[[str], int]:
    """An argparse type: an integer from ``lo`` to ``hi``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer (from {lo} to {hi})") from None
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"{value} is not an integer from {lo} to {hi}")
        return value

    parse.__name__ = "integer"
    return parse


def float_in(lo: float, hi: float, lo_open: bool = False) -> Callable[[str], float]:
    """An argparse type: a finite number from ``lo`` (excluded if ``lo_open``) to ``hi``."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        above = value > lo if lo_open else value >= lo
        if not (math.isfinite(value) and above and value <= hi):
            raise argparse.ArgumentTypeError(
                f"{value:g} is not a finite number {'above' if lo_open else 'from'} {lo:g} "
                f"{'and at most' if lo_open else 'to'} {hi:g}")
        return value

    parse.__name__ = "number"
    return parse


def side(text: str) -> int:
    """An argparse type: a film width or height, :data:`MIN_SIDE` to :data:`MAX_SIDE` pixels."""
    return int_in(MIN_SIDE, MAX_SIDE)(text)


def scene_file(text: str) -> Path:
    """An argparse type: a scene file. A missing path passes (the scene loader names it with its hint); a
    folder, a device, a FIFO or a socket is refused as what it is."""
    path = Path(text).expanduser()
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        return path
    except OSError as exc:
        raise argparse.ArgumentTypeError(f"{text}: cannot be read ({exc.strerror})") from None
    if stat.S_ISDIR(mode):
        xml = sorted(p.name for p in path.glob("*.xml"))
        hint = f" (it holds {', '.join(xml[:5])})" if xml else ""
        raise argparse.ArgumentTypeError(f"{text} is a folder; give the Mitsuba 3 scene's .xml file in "
                                         f"it{hint}")
    if not stat.S_ISREG(mode):
        what = ("a FIFO" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode)
                else "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "not a regular file")
        raise argparse.ArgumentTypeError(f"{text} is {what}; give a Mitsuba 3 scene .xml file")
    return path
