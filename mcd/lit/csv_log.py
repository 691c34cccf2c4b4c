"""Training curves that survive a resume (docs/reliability.md, "Resumable training").

Lightning's ``CSVLogger`` deletes an existing ``metrics.csv`` when a run resumes into the same directory, so
the curve before the resume is lost. :class:`ResumableCSVLogger` appends to it instead, keeping its columns
(a column new in the resumed run rewrites the header over the union; earlier rows leave it empty). The rows a
killed process logged after the checkpoint a run resumes from are dropped when the resumed run starts
(:func:`drop_rows_after`, called by ``mcd.lit.budget.LearningCurve`` for ``metrics.csv`` and ``curve.csv``),
so each step appears once.
"""

from __future__ import annotations

import csv
from pathlib import Path

from lightning.fabric.loggers.logger import rank_zero_experiment
from lightning.pytorch.loggers import CSVLogger
from lightning.pytorch.loggers.csv_logs import ExperimentWriter

from mcd.core.atomic_write import atomic_write


class _AppendingWriter(ExperimentWriter):
    """Lightning's CSV writer, keeping an earlier ``metrics.csv`` and its header instead of deleting it."""

    def _check_log_dir_exists(self) -> None:
        if self._fs.isfile(self.metrics_file_path):
            with self._fs.open(self.metrics_file_path, "r", newline="") as f:
                self.metrics_keys = next(csv.reader(f), [])


class ResumableCSVLogger(CSVLogger):
    """``CSVLogger`` whose ``metrics.csv`` is appended to when a resumed run writes into the same folder."""

    @property
    @rank_zero_experiment
    def experiment(self) -> ExperimentWriter:
        """The writer (created on first use, like Lightning's)."""
        if self._experiment is None:
            self._fs.makedirs(self.root_dir, exist_ok=True)
            self._experiment = _AppendingWriter(log_dir=self.log_dir)
        return self._experiment


def drop_rows_after(path: Path, step: int) -> int:
    """Rewrite the CSV file at ``path`` (atomically, :mod:`mcd.core.atomic_write`) without its rows whose
    ``step`` column exceeds ``step`` (those of a killed process, past the checkpoint a run resumed from);
    returns how many were dropped. A missing file, or one without a ``step`` column, is left alone."""
    if not path.is_file():
        return 0
    with path.open(newline="") as f:
        reader = csv.DictReader(f)
        rows = list(reader)
        fields = reader.fieldnames or []
    if "step" not in fields:
        return 0
    kept = [r for r in rows if not r["step"] or float(r["step"]) <= step]
    if len(kept) == len(rows):
        return 0

    def write(tmp: Path) -> None:
        with tmp.open("w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=fields)
            writer.writeheader()
            writer.writerows(kept)

    atomic_write(path, write)
    return len(rows) - len(kept)
