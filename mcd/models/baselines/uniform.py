"""The uniform render at the budget, ``c{s}``, that the uniform baselines read (architecture.md "The store":
"Uniform methods at budget s read ``c{s}``"; docs/benchmark.md "Experiments")."""

from __future__ import annotations

UNIFORM_BUDGETS = (1, 2, 4, 8, 16, 32)


def uniform_key(budget: float, method: str) -> str:
    """The buffer name ``c{budget}``; a ``ValueError`` when the store has no uniform render at that budget."""
    if budget not in UNIFORM_BUDGETS:
        raise ValueError(f"{method}: budget={budget} has no uniform render in the store "
                         f"(c1 c2 c4 c8 c16 c32); set budget to one of {list(UNIFORM_BUDGETS)}")
    return f"c{int(budget)}"
