"""The component switches ``UN AS KP PP FG SA`` (method.md, "The five switches") and their dependencies."""

from __future__ import annotations

from collections.abc import Mapping

SWITCHES = ("UN", "AS", "KP", "PP", "FG", "SA")

#: switch -> (switch it needs, why).
NEEDS = {
    "KP": ("AS", "the kernel pool and kernel map are computed from the sampling network F_s's features"),
    "FG": ("AS", "Fast GhostConv is the building block of the sampling network F_s"),
}


def check_switches(method: Mapping[str, object]) -> None:
    """Raise ``ValueError`` for an impossible switch combination: KP or FG without AS; UN off (two_stage).

    Keys that a method does not have (a baseline without switches) are not checked.
    """
    for key in SWITCHES:
        if key in method and not isinstance(method[key], bool):
            raise ValueError(f"method.{key} must be true or false, got {method[key]!r}")
    if method.get("name") == "two_stage" and method.get("UN") is False:
        raise ValueError("method.UN=false: the denoiser F_d (UN) is on in every row A-M; set method.UN=true")
    for key, (need, why) in NEEDS.items():
        if method.get(key) and not method.get(need, False):
            raise ValueError(f"method.{key}=true needs method.{need}=true: {why} (method.md, 'The five "
                             f"switches'). Set method.{need}=true or method.{key}=false.")


def switch_row(method: Mapping[str, object]) -> str:
    """The switches as method.md writes a row, e.g. ``111111`` for F."""
    return "".join("1" if method.get(k) else "0" for k in SWITCHES)
