"""Models (docs/architecture.md "Models"): the two-stage network's components and the method registry.

``build(cfg)`` returns the method named by ``cfg.method.name``; ``register(name)`` adds one.
"""

from mcd.models.registry import REGISTRY, build, register

__all__ = ["REGISTRY", "build", "register"]
