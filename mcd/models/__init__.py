"""Models (docs/architecture.md "Models"): the two-stage network's components and the method registry.

``build(cfg)`` returns the method named by ``cfg.method.name``; ``register(name)`` adds one to ``METHODS``.

``mcd.models.registry`` (and so torch) is imported on first use of these names, so that the light modules of
this package (``switches``) load without torch (docs/architecture.md, "Start-up").
"""

from typing import Any

__all__ = ["METHODS", "build", "register"]


def __getattr__(name: str) -> Any:
    """``METHODS``, ``build`` and ``register`` from :mod:`mcd.models.registry`, imported on first use."""
    if name in __all__:
        from mcd.models import registry

        return getattr(registry, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
