"""``trainer.precision=auto`` (mcd/lit/precision.py, docs/training.md "Throughput"): bf16-mixed on a CPU with
native bf16 (the measured default), fp32 on one without, explicit values unchanged."""

from __future__ import annotations

import logging

import pytest

from mcd.lit import precision


@pytest.mark.parametrize("native", [True, False])
def test_auto_on_cpu_follows_native_bf16(monkeypatch, caplog, native):
    monkeypatch.setattr(precision, "cpu_bf16_supported", lambda: native)
    with caplog.at_level(logging.INFO, logger=precision.__name__):
        chosen = precision.resolve("auto", "cpu")
    assert chosen == ("bf16-mixed" if native else "32-true")
    assert f"-> {chosen}" in caplog.text and ("no native bf16" in caplog.text) != native


def test_explicit_precision_passes_through(monkeypatch):
    monkeypatch.setattr(precision, "cpu_bf16_supported", lambda: True)
    assert precision.resolve("32-true", "cpu") == "32-true"
    assert precision.resolve("bf16-mixed", "cpu") == "bf16-mixed"

