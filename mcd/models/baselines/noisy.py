"""The noisy input itself as a row of the baselines table (docs/benchmark.md "Experiments"): the uniform
render
at the budget, no parameters, no training (``method.trainable: false``)."""

from __future__ import annotations

from torch import Tensor, nn

from mcd.models.baselines.uniform import uniform_key
from mcd.models.inputs import need
from mcd.models.registry import register


class Noisy(nn.Module):
    """Returns ``c{budget}`` unchanged."""

    window = (0, 0)
    temporal_state = False  # no network

    def __init__(self, budget: int) -> None:
        super().__init__()
        self.key = uniform_key(budget, "noisy")

    def required_buffers(self) -> set[str]:
        return {self.key}

    def reset(self) -> None:
        """Stateless."""

    def forward(self, x: dict[str, Tensor | None]) -> dict[str, Tensor]:
        return {"output": need(x, self.key, "noisy").clone()}


#: Its catalogue entries (mcd.config.methods.Method's fields; read from this file without importing it,
#: docs/architecture.md "Methods").
ENTRIES = (
    {"experiment": "noisy", "display": "Noisy input", "table1": True, "bench": True},
)


@register("noisy")
def build_noisy(*, budget: float) -> Noisy:
    """The noisy input at ``budget``."""
    return Noisy(budget)
