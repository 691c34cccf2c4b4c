"""Models (docs/architecture.md "Models"): the two-stage network's components and the method registry.

``build(cfg)`` returns the method named by ``cfg.method.name``; ``register(name)`` adds one to ``METHODS``.
"""

from mcd.models.registry import METHODS, build, register

__all__ = ["METHODS", "build", "register"]
