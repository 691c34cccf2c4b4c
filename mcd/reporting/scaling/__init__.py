"""The scaling study's report (docs/benchmark.md "Scaling report"): how the methods' errors move as the
training data and the optimiser steps grow, from the runs of ``+sweep=scaling`` (``conf/sweep/scaling.yaml``).

One module per part: ``grid`` (the runs at their scale points, and the seeds' statistics per cell),
``coverage`` (the sweep's plan against the runs present), ``gaps`` (F - NTASAD, F - A and the other pairs per
scale point), ``fit`` (PSNR against log10 steps, and where F and NTASAD cross), ``plot`` (``scaling.png``),
``notes`` (the generated ``notes.md``) and ``report`` (the report's files and README, which
:func:`mcd.report.make_report` calls).
"""
