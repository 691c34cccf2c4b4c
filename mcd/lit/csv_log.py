"""Training curves that survive a resume (docs/reliability.md, "Resumable training").

Lightning's ``CSVLogger`` deletes an existing ``metrics.csv`` when a run resumes into the same directory, so
the curve before the resume is lost. :class:`ResumableCSVLogger` appends to it instead, keeping its columns
(a column new in the resumed run rewrites the header over the union; earlier rows leave it empty). Steps
logged after the checkpoint a run resumed from appear twice (once from each process).
"""

from __future__ import annotations

import csv

from lightning.fabric.loggers.logger import rank_zero_experiment
from lightning.pytorch.loggers import CSVLogger
from lightning.pytorch.loggers.csv_logs import ExperimentWriter


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
