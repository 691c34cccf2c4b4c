"""``trainer.accelerator`` and ``trainer.devices`` checked against the devices the host has, before any work
(docs/reliability.md, "Campaign fixes").

Lightning checks both when the trainer is built, which ``mcd.run`` does after the store is rendered: on a
machine without a GPU, ``trainer.accelerator=gpu`` rendered the whole store and then failed with "No supported
gpu backend found!", naming no key. :func:`check` asks Lightning's own accelerators
(``AcceleratorRegistry``, ``is_available``, ``auto_device_count``) first.
"""

from __future__ import annotations

from typing import Any


def check(accelerator: Any, devices: Any) -> None:
    """ValueError naming ``trainer.accelerator`` when Lightning does not know it or the host has no such
    device, or ``trainer.devices`` when it asks for more devices of it than there are."""
    from lightning.pytorch.accelerators import AcceleratorRegistry, CUDAAccelerator, MPSAccelerator

    name = str(accelerator)
    if name in ("auto", "cpu"):
        return
    if name == "gpu":
        found = [a for a in (CUDAAccelerator, MPSAccelerator) if a.is_available()]
    elif name in AcceleratorRegistry:
        kind = AcceleratorRegistry[name]["accelerator"]
        found = [kind] if kind.is_available() else []
    else:
        raise ValueError(f"trainer.accelerator={name}: give one of auto, cpu, gpu, "
                         f"{', '.join(a for a in AcceleratorRegistry if a != 'cpu')}")
    if not found:
        raise ValueError(f"trainer.accelerator={name}: this machine has no such device (Lightning finds "
                         "none); give trainer.accelerator=cpu, or auto to take what there is")
    count = found[0].auto_device_count()
    if isinstance(devices, int) and not isinstance(devices, bool) and devices > count:
        raise ValueError(f"trainer.devices={devices}: this machine has {count} {name} device(s); give at "
                         f"most {count}, or -1 for every one")
