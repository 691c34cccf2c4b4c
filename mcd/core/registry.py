"""One registry type for everything chosen by name in a config (docs/architecture.md, "Config").

A :class:`Registry` maps a name (``method.name``, ``loss.name``) to a constructor that takes that part's
own settings. Its instances are :data:`mcd.models.registry.METHODS` and :data:`mcd.losses.LOSSES`.
Built-in entries register themselves when their module is imported; the registry imports its ``builtin``
modules the first time a name is looked up that is not registered yet. A plug-in registers with
``@REGISTRY.register(name)`` in a module that is imported before the lookup (the same rule for every
registry).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Generic, TypeVar

T = TypeVar("T", bound=Callable[..., object])


class UnknownName(KeyError, ValueError):
    """A name no entry of a registry has (a ``KeyError`` and a ``ValueError``; its message is plain text)."""

    def __str__(self) -> str:
        return str(self.args[0])


class Registry(Generic[T]):
    """Name -> constructor, for one kind of part (``kind``: ``method``, ``loss``; it names the config key
    ``<kind>.name`` in errors). ``builtin``: modules whose import registers the built-in entries."""

    def __init__(self, kind: str, builtin: tuple[str, ...] = ()) -> None:
        self.kind = kind
        self.builtin = builtin
        self._entries: dict[str, T] = {}

    def register(self, name: str) -> Callable[[T], T]:
        """Decorator: register a constructor under ``name`` (a name may be registered once)."""

        def deco(constructor: T) -> T:
            known = self._entries.get(name)
            if known is not None and known is not constructor:
                raise ValueError(f"{self.kind} {name!r} is registered twice ({known} and {constructor})")
            self._entries[name] = constructor
            return constructor

        return deco

    def unregister(self, name: str) -> None:
        """Remove ``name`` (tests that register a temporary entry)."""
        self._entries.pop(name, None)

    def load_builtin(self, until: str | None = None) -> None:
        """Import the built-in modules, stopping once ``until`` is registered."""
        for module in self.builtin:
            if until is not None and until in self._entries:
                return
            importlib.import_module(module)

    def get(self, name: str) -> T:
        """The constructor registered as ``name``; :class:`UnknownName` naming ``<kind>.name`` and the
        choices."""
        self.load_builtin(until=name)
        if name not in self._entries:
            raise UnknownName(f"unknown {self.kind}.name={name!r}; registered: {self.names()} (a plug-in "
                              f"registers with @register({name!r}) in a module imported before the run)")
        return self._entries[name]

    def names(self) -> list[str]:
        """Every registered name, built-ins included, sorted."""
        self.load_builtin()
        return sorted(self._entries)
