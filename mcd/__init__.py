"""mcd: Monte Carlo rendering denoising research platform.

Implements "Two-Stage Monte Carlo Denoising with Adaptive Sampling and Kernel Pool" (Xiang et al.) and its
baselines on Mitsuba 3 renders, as a Hydra + Lightning experiment platform. See docs/architecture.md.
"""

__version__ = "0.1.0"
