"""Stage labels of the two-stage model's forward, and a clock that reads them (docs/inference.md "Stage
profile").

:func:`stage` wraps a part of a forward in a ``torch.profiler.record_function`` label of that name. While a
:class:`StageClock` is active (``with clock:``), each label's entry and exit is also a boundary on that clock,
and the time (or the count, for :class:`FlopClock`) between two consecutive boundaries goes to the innermost
label open between them. Each stage's figure is therefore *exclusive* (a nested label's time is not its
parent's), and the stages, with ``other`` for the time outside every label, add up to the clock's span by
construction; :mod:`mcd.bench.profile` checks that span against the frame's wall time.

On CUDA a boundary is a ``torch.cuda.Event`` recorded on the current stream (read after one synchronize at the
end), so the clock measures the GPU's timeline without stalling the launches; on the CPU it is
``time.perf_counter``. A label costs one ``None`` test when no clock is active, and nothing under
``torch.compile`` tracing.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager

import torch
from torch.profiler import record_function


class StageClock:
    """Exclusive time per label path (``"F_d/L0/PP"``) between its boundaries; ``device`` picks CUDA events or
    ``perf_counter``."""

    def __init__(self, device: torch.device | str = "cpu") -> None:
        self.cuda = torch.device(device).type == "cuda"
        self.stack: list[str] = []
        self.marks: list[tuple[object, str]] = []   # (timestamp, path of the segment that ends there)
        self._outer: StageClock | None = None

    def stamp(self) -> object:
        """A timestamp: a recorded CUDA event, or seconds."""
        if self.cuda:
            event = torch.cuda.Event(enable_timing=True)
            event.record()
            return event
        return time.perf_counter()

    def boundary(self) -> None:
        """Close the current segment, which belongs to the innermost open label (``""``: none)."""
        self.marks.append((self.stamp(), "/".join(self.stack)))

    def enter(self, name: str) -> None:
        self.boundary()
        self.stack.append(name)

    def exit(self) -> None:
        self.boundary()
        self.stack.pop()

    def elapsed(self, start: object, end: object) -> float:
        """Milliseconds between two timestamps."""
        if self.cuda:
            return start.elapsed_time(end)  # type: ignore[attr-defined]
        return (end - start) * 1e3  # type: ignore[operator]

    def __enter__(self) -> StageClock:
        global _ACTIVE
        self._outer, _ACTIVE = _ACTIVE, self
        self.marks = [(self.stamp(), "")]
        return self

    def __exit__(self, *exc: object) -> None:
        global _ACTIVE
        self.boundary()
        _ACTIVE = self._outer
        if self.cuda:
            torch.cuda.synchronize()

    def totals(self) -> dict[str, float]:
        """Exclusive figure per label path in the order the paths first closed (``""``: outside every label);
        they sum to :meth:`span`."""
        out: dict[str, float] = {}
        for (start, _), (end, path) in zip(self.marks, self.marks[1:], strict=False):
            out[path] = out.get(path, 0.0) + self.elapsed(start, end)
        return out

    def span(self) -> float:
        """From the clock's first boundary to its last."""
        return self.elapsed(self.marks[0][0], self.marks[-1][0])


class FlopClock(StageClock):
    """The same segments counted in a ``FlopCounterMode``'s FLOPs instead of time (:meth:`totals`: FLOPs)."""

    def __init__(self, counter) -> None:
        super().__init__("cpu")
        self.counter = counter

    def stamp(self) -> object:
        return self.counter.get_total_flops()

    def elapsed(self, start: object, end: object) -> float:
        return float(end - start)  # type: ignore[operator]


_ACTIVE: StageClock | None = None


@contextmanager
def stage(name: str) -> Iterator[None]:
    """A labelled stage: a profiler label, and a pair of boundaries on the active :class:`StageClock`."""
    clock = None if torch.compiler.is_compiling() else _ACTIVE
    with record_function(name):
        if clock is None:
            yield
            return
        clock.enter(name)
        try:
            yield
        finally:
            clock.exit()
