"""Provenance of a report (docs/benchmark.md "Reports": every report names command, config, data profile,
commit, device): gathered from the runs themselves, printed in the README and under every figure."""

from __future__ import annotations

import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path

from matplotlib.figure import Figure

from mcd.core.provenance import commit_word, short_commit
from mcd.reporting.markdown_text import escape as esc
from mcd.reporting.records import RECORDS_DIR
from mcd.reporting.runs import Run, Sweep


def _distinct(values: list[object]) -> str:
    seen = sorted({str(v) for v in values if v not in (None, "")})
    return ", ".join(seen) if seen else "unknown"


def _segment_text(seg: dict) -> str:
    """One training segment (mcd/lit/segments.py) as the report prints it: steps, commit, precision (where
    recorded), minutes."""
    steps = ("" if seg.get("start_step") is None or seg.get("end_step") is None
             else f"steps {seg['start_step']}-{seg['end_step']} ")
    code = (f"at {commit_word(seg['commit'], seg.get('dirty'), 7)}" if seg.get("commit")
            else "code not recorded")
    precision = f" in {seg['precision']}" if seg.get("precision") else ""
    minutes = "" if seg.get("seconds") is None else f", {float(seg['seconds']) / 60:.0f} min"
    return f"{steps}{code}{precision}{minutes}"


@dataclass
class Provenance:
    """What produced a report: the sweep commands and what the runs recorded about themselves."""

    sweeps: list[Sweep]
    runs: list[Run]
    report_command: str
    report_commit: str

    @classmethod
    def gather(cls, sweeps: list[Sweep], runs: list[Run], command: str | None = None) -> Provenance:
        return cls(
            sweeps=sweeps,
            runs=runs,
            report_command=command or "python -m mcd.report " + " ".join(sys.argv[1:]),
            report_commit=short_commit(),
        )

    def _ok(self) -> list[Run]:
        return [r for r in self.runs if r.metrics is not None]

    @property
    def data_profiles(self) -> str:
        return _distinct([r.data_profile for r in self.runs])

    @property
    def commits(self) -> str:
        """Every commit that trained or tested a finished run: each run's own and those of the earlier
        processes of a resumed run (``Run.segments``)."""
        seen = [
            commit_word(c["commit"], c.get("dirty"), None)
            for r in self._ok()
            for c in [r.metrics, *r.segments]
            if c.get("commit")
        ]
        return _distinct(seen)  # type: ignore[arg-type]

    @property
    def resumed(self) -> str:
        """The finished runs trained in more than one process, with the code behind each stretch of steps
        (``Run.segments``); "none" when every run trained in one go."""
        parts = [f"`{r.path.name}` ({'; '.join(_segment_text(seg) for seg in r.segments)})"
                 for r in self._ok() if len(r.segments) > 1]
        return "; ".join(parts) if parts else "none"

    @property
    def earlier_s(self) -> float:
        """Training seconds of the finished runs' earlier processes (every segment but the last, where
        recorded): wall time that no ``wall_s`` holds."""
        return float(sum(float(seg.get("seconds") or 0.0) for r in self._ok() for seg in r.segments[:-1]))

    @property
    def devices(self) -> str:
        return _distinct([r.metrics.get("device") for r in self._ok()])

    @property
    def config_groups(self) -> str:
        """Capacity / train / trainer profiles of the runs (the `config` part of the provenance)."""
        parts = []
        for group in ("capacity", "train", "trainer", "loss"):
            profiles = _distinct([r.choices.get(group) for r in self.runs])
            if profiles != "unknown":
                parts.append(f"{group}={profiles}")
        return " ".join(parts) or "see each run's .hydra/config.yaml"

    @property
    def wall_s(self) -> float:
        """Total wall time of the finished runs, seconds: each run's ``wall_s`` (its last process) plus the
        training time of a resumed run's earlier processes (:attr:`earlier_s`)."""
        return float(sum(float(r.metrics.get("wall_s") or 0.0) for r in self._ok())) + self.earlier_s

    @property
    def training(self) -> str:
        """Training budget of the trained runs (epochs, optimiser steps) and the perceptual loss status."""
        trained = [
            r.metrics for r in self._ok() if r.metrics.get("trained", True) and "train_steps" in r.metrics
        ]
        if not trained:
            return "no trained runs"
        epochs = sorted({int(m.get("epochs", 0)) for m in trained})
        steps = sorted({int(m["train_steps"]) for m in trained})
        perceptual = _distinct(
            [
                "on"
                if (m.get("perceptual_loss") or {}).get("on")
                else f"off ({(m.get('perceptual_loss') or {}).get('reason', 'no reason recorded')})"
                for m in trained
            ]
        )

        def span(v: list[int]) -> str:
            return str(v[0]) if v[0] == v[-1] else f"{v[0]}..{v[-1]}"

        return (
            f"{len(trained)} trained runs, epochs {span(epochs)}, optimiser steps {span(steps)}; "
            f"perceptual loss: {perceptual}"
        )

    @property
    def reference_quality(self) -> str:
        """Per scene, the test frames' reference spp and estimated PSNR (docs/data.md, "Reference quality")
        as the runs' stores reported them; runs from before that record say nothing."""
        seen: dict[str, dict] = {}
        for r in self._ok():
            for scene, q in ((r.metrics.get("data") or {}).get("reference") or {}).items():
                seen.setdefault(scene, q)
        if not seen:
            return "not recorded by these runs (stores from before docs/data.md \"Reference quality\")"

        def one(scene: str, q: dict) -> str:
            if q.get("test_psnr_db") is None:
                return f"{scene} {q.get('train_spp')} spp (no estimate)"
            low = q.get("test_psnr_min_db")
            return (f"{scene} {q['test_spp']} spp, {q['test_psnr_db']:.1f} dB (lowest frame {low:.1f})")

        target = _distinct([q.get("target_db") for q in seen.values()])
        return f"target {target} dB; " + "; ".join(one(s, q) for s, q in sorted(seen.items()))

    def readme_lines(self, root: Path, regenerate: str, notes: list[str], report_s: float) -> list[str]:
        """The "Provenance" section of a report's README (``mcd.report``, ``mcd.reporting.scaling.report``),
        whose ``- <label>: `` lines the reports index reads (``mcd.reporting.index.describe``): the sweep
        commands (``root``: the folder paths are shown relative to), the runs' data, config, training,
        commits, devices, resumed runs and wall time, the run records and ``regenerate`` (the command that
        rebuilds the report from them), the jobs' states and ``notes``. Text from the runs' records passes
        :func:`mcd.reporting.markdown_text.escape`."""
        n_ok = sum(r.status == "ok" for r in self.runs)
        return [
            "## Provenance",
            "",
            f"- Sweep commands ({len(self.sweeps)}):",
            *[
                f"  - `{esc(s.command)}` → "
                f"`{s.path.relative_to(root) if s.path.is_relative_to(root) else s.path}` "
                f"(data profile `{esc(s.data_profile)}`)"
                for s in self.sweeps
            ],
            f"- Data profile(s): {esc(self.data_profiles)}",
            f"- Reference quality of the test frames (estimated PSNR of each reference, docs/data.md): "
            f"{esc(self.reference_quality)}",
            f"- Config: {esc(self.config_groups)}; each job's full config is in `<run>/.hydra/config.yaml` "
            "(and `resolved_config.yaml`)",
            f"- Training: {esc(self.training)}",
            f"- Commit(s) of the runs: {esc(self.commits)}",
            f"- Device(s): {esc(self.devices)}",
            f"- Resumed runs (trained in more than one process; metrics.json `segments`, else the excess of "
            f"curve.csv's clock over the last process's training time): {esc(self.resumed)}",
            f"- Wall time: {self.wall_s / 60:.1f} min summed over {n_ok} finished runs (each run's `wall_s`, "
            f"plus {self.earlier_s / 60:.1f} min of resumed runs' earlier processes); this report took "
            f"{report_s:.1f} s",
            f"- Run records: [{RECORDS_DIR}/]({RECORDS_DIR}/) holds each run's `metrics.json`, "
            "`curve.csv`, `frames.csv`, `edges.json` and `.hydra/` config, and each sweep's `multirun.yaml`: "
            f"`{regenerate}` regenerates every table, "
            "finding and curve from them (not the strips, which need the runs' `samples/`)",
            f"- Jobs: {len(self.runs)} found, {n_ok} finished, "
            f"{sum(r.status == 'failed' for r in self.runs)} failed, "
            f"{sum(r.status == 'incomplete' for r in self.runs)} incomplete",
            *[f"- Note: {n}" for n in notes],
        ]

    def commands(self) -> list[str]:
        return [s.command for s in self.sweeps]

    def footer(self, sweep_names: list[str] | None = None) -> str:
        """Two lines for the foot of a figure: the sweep command(s), profile, commit, device."""
        sweeps = [s for s in self.sweeps if sweep_names is None or s.name in sweep_names] or self.sweeps
        cmds = " ; ".join(s.command for s in sweeps) or "runs: " + ", ".join(
            sorted({r.sweep for r in self.runs})
        )
        return (
            f"{cmds}\n"
            f"data profile {self.data_profiles} | {self.config_groups} | commit {self.commits} | "
            f"device {self.devices} | report {self.report_commit}"
        )

    def stamp(self, fig: Figure, sweep_names: list[str] | None = None) -> None:
        """Write the footer under a figure, wrapped to its width, and leave room for it at the bottom."""
        width_in, height_in = fig.get_size_inches()
        chars = max(40, int(width_in * 72 / (6 * 0.6)))  # monospace 6 pt: about 3.6 pt per character
        lines = [w for line in self.footer(sweep_names).splitlines() for w in textwrap.wrap(line, chars)]
        fig.text(0.005, 0.005, "\n".join(lines), fontsize=6, family="monospace", va="bottom")
        footer = (len(lines) * 6 * 1.2 + 4) / 72 / height_in
        fig.subplots_adjust(bottom=footer + max(fig.subplotpars.bottom, 0.1))

    def save(self, fig: Figure, path: Path, dpi: int = 120, sweep_names: list[str] | None = None) -> Path:
        """Stamp the provenance footer on a figure, write it as PNG to ``path`` and close it."""
        import matplotlib.pyplot as plt

        self.stamp(fig, sweep_names)
        fig.savefig(path, dpi=dpi)
        plt.close(fig)
        return path
