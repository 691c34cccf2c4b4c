"""The component switches ``UN AS KP PP FG SA`` and their dependencies (docs/method.md, "The five switches").

One definition serves the config-time check of ``mcd.run`` (before anything is rendered) and the build-time
check of the two-stage model.
"""

from __future__ import annotations

from collections.abc import Mapping

SWITCHES = ("UN", "AS", "KP", "PP", "FG", "SA")

#: switch -> (switch it needs, why).
NEEDS = {
    "KP": ("AS", "the kernel pool and kernel map are computed from the sampling network F_s's features"),
    "FG": ("AS", "Fast GhostConv is the building block of the sampling network F_s"),
}


def check_switches(method: Mapping[str, object], *, complete: bool = False) -> dict[str, bool]:
    """The six switches as booleans; ``ValueError`` saying why for an impossible combination.

    ``complete=True`` (the two-stage model) requires every switch; otherwise keys a method lacks (a baseline
    without switches) are not checked. UN must stay on for the two-stage model (every row A-M has it).
    """
    missing = [s for s in SWITCHES if s not in method]
    if complete and missing:
        raise ValueError(f"method config lacks switches {missing}; set method.{{{','.join(SWITCHES)}}} "
                         "(true/false)")
    for key in SWITCHES:
        if key in method and not isinstance(method[key], bool):
            raise ValueError(f"method.{key} must be true or false (booleans), got {method[key]!r}")
    if (complete or method.get("name") == "two_stage") and method.get("UN") is False:
        raise ValueError("method.UN=false: the denoiser F_d (UN) is on in every row A-M; set method.UN=true, "
                         "or use method.name=noisy for the noisy input")
    for key, (need, why) in NEEDS.items():
        if method.get(key) and not method.get(need, False):
            raise ValueError(f"method.{key}=true needs method.{need}=true: {why} (docs/method.md, 'The five "
                             f"switches'). Set method.{need}=true or method.{key}=false.")
    return {s: bool(method.get(s, False)) for s in SWITCHES}


def switch_row(method: Mapping[str, object]) -> str:
    """The switches as docs/method.md writes a row, e.g. ``111111`` for F."""
    return "".join("1" if method.get(k) else "0" for k in SWITCHES)
