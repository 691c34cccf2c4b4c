"""The uniform render at the budget, ``c{s}``, that the uniform baselines read (architecture.md "The store":
"Uniform methods at budget s read ``c{s}``"; docs/benchmark.md "Experiments"; the buffers:
:mod:`mcd.data.buffers`)."""

from __future__ import annotations

from mcd.data.buffers import SPP_BUFFERS, UNIFORM_BUDGETS, uniform_buffer


def uniform_key(budget: float, method: str) -> str:
    """The buffer name ``c{budget}``; a ``ValueError`` when the store has no uniform render at that budget."""
    if budget not in UNIFORM_BUDGETS:
        raise ValueError(f"{method}: budget={budget} has no uniform render in the store "
                         f"({' '.join(SPP_BUFFERS)}); set budget to one of {list(UNIFORM_BUDGETS)}")
    return uniform_buffer(budget)
