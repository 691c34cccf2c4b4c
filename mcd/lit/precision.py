"""``trainer.precision=auto``: the fastest training precision that keeps accuracy on the machine it runs on
(docs/training.md, "Throughput", where the choice is measured with ``python -m mcd.bench --train``).

- CUDA: ``bf16-mixed`` where the GPU supports bf16, else ``32-true``.
- CPU: ``bf16-mixed`` only where the CPU computes bf16 natively (``avx512_bf16`` or ``amx_bf16``) *and*
  :data:`CPU_BF16_PAYS` says the benchmark found it faster; else ``32-true``.
Any other value of ``trainer.precision`` is Lightning's and passes through unchanged, with two exceptions
checked before any work: ``16-mixed`` on the CPU, where Lightning trains in ``bf16-mixed`` instead, resolves
to ``bf16-mixed`` (so the run's record says what ran), and a value Lightning does not know, a 64-bit one or
one with half-precision weights (``bf16-true``, ``16-true``: the data are float32, so the first step fails)
is refused naming the key. The choice is logged.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Iterator

import torch

log = logging.getLogger(__name__)

#: Whether bf16-mixed training beat fp32 on a bf16-capable CPU in the throughput benchmark
#: (reports/bench/train.csv; docs/training.md "Throughput").
CPU_BF16_PAYS = True


def cpu_bf16_supported() -> bool:
    """Whether this CPU computes bf16 natively (AVX512-BF16 or AMX); emulated bf16 is slower than fp32."""
    checks = ("_is_avx512_bf16_supported", "_is_amx_tile_supported")
    return any(bool(getattr(torch.cpu, c, lambda: False)()) for c in checks)


@contextlib.contextmanager
def autocast_to(device: torch.device, dtype: torch.dtype | None) -> Iterator[None]:
    """``torch.autocast`` to ``dtype`` on ``device``'s type; nothing for ``None`` (fp32)."""
    if dtype is None:
        yield
    else:
        with torch.autocast(device_type=device.type, dtype=dtype):
            yield


def on_cpu(accelerator: str) -> bool:
    """Whether a Trainer with this ``accelerator`` trains on the CPU."""
    return accelerator == "cpu" or (accelerator == "auto" and not torch.cuda.is_available())


#: The values of ``trainer.precision`` a run may have (``auto`` and Lightning's, less the 64-bit ones and
#: :data:`HALF_WEIGHTS`).
CHOICES = ("auto", "32-true", "32", "bf16-mixed", "16-mixed", "bf16", "16")
#: Lightning's precisions that cast the weights to half: the clips reach the model in float32, so the first
#: training step failed ("Input type (float) and bias type (c10::BFloat16) should be the same"), after the
#: store was rendered.
HALF_WEIGHTS = ("bf16-true", "16-true")


def check(precision: str) -> None:
    """ValueError naming the key for a ``trainer.precision`` outside :data:`CHOICES`."""
    if precision in HALF_WEIGHTS:
        raise ValueError(f"trainer.precision={precision}: half-precision weights are not supported (the "
                         f"clips are float32 and the first step fails); give bf16-mixed (or 16-mixed on a "
                         f"GPU), or one of {', '.join(CHOICES)}")
    if precision not in CHOICES:
        raise ValueError(f"trainer.precision={precision}: give one of {', '.join(CHOICES)} (64-bit training "
                         "is not supported: the data are float32)")


def resolve(precision: str, accelerator: str) -> str:
    """Lightning's precision for ``trainer.precision`` (``auto`` resolved as the module docstring says);
    ValueError naming the key for a value outside :data:`CHOICES` (:func:`check`)."""
    check(precision)
    if precision in ("16-mixed", "16") and on_cpu(accelerator):
        log.info("trainer.precision=%s -> bf16-mixed (fp16 autocast is a GPU's; Lightning trains in "
                 "bf16-mixed on the CPU)", precision)
        return "bf16-mixed"
    if precision != "auto":
        return precision
    if not on_cpu(accelerator):
        chosen = "bf16-mixed" if torch.cuda.is_bf16_supported() else "32-true"
        why = "the GPU supports bf16" if chosen == "bf16-mixed" else "the GPU has no bf16"
    else:
        native = cpu_bf16_supported()
        chosen = "bf16-mixed" if native and CPU_BF16_PAYS else "32-true"
        why = ("this CPU has native bf16 and bf16 measured faster" if chosen == "bf16-mixed"
               else "this CPU has no native bf16" if not native
               else "bf16-mixed measured no faster than fp32 on CPU (docs/training.md, 'Throughput')")
    log.info("trainer.precision=auto -> %s (%s)", chosen, why)
    return chosen
