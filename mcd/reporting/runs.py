"""Finding and reading the run directories of `python -m mcd.run` sweeps
(docs/architecture.md "Run directory").

A run directory is any folder holding `metrics.json` (finished), `error.json` (failed) or Hydra's
`.hydra/config.yaml` (started, neither finished nor failed: killed, or still running). A sweep directory holds
Hydra's `multirun.yaml`, which records the command line that launched it.
"""

from __future__ import annotations

import json
import logging
import math
import types
import typing
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import pandas as pd
import yaml
from omegaconf import OmegaConf

from mcd.core.config_rules import ConfigError, checked
from mcd.core.metrics import FRAME_METRICS, MODEL_METRICS, PSNR_CAP_DB
from mcd.core.paths import SAFE_NAME
from mcd.lit.run_record import RunRecord

log = logging.getLogger(__name__)

#: The file the lab's ``tools/edge_effect.py`` writes into a run directory, read beside its metrics.
EDGES_FILE = "edges.json"
#: The sampling and kernel maps' border figures in that file, where a model has the maps.
MAP_KEYS = ("map_border_ratio", "index_border", "index_interior")

def _load_json(path: Path) -> dict[str, Any] | None:
    """The JSON object in `path`, or None when the file is missing, truncated or not an object."""
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def _load_yaml(path: Path) -> dict[str, Any]:
    """A Hydra-saved YAML file as a plain dict, interpolations resolved where they resolve ({} if absent)."""
    if not path.is_file():
        return {}
    cfg = OmegaConf.load(path)
    try:
        return OmegaConf.to_container(cfg, resolve=True)  # type: ignore[return-value]
    except Exception:  # an interpolation into the `hydra` node, which is not saved with the job config
        return OmegaConf.to_container(cfg, resolve=False)  # type: ignore[return-value]


#: Seconds by which a run's learning-curve clock may exceed its last process's training time before the run
#: counts as resumed (``Run.segments``). In a run trained in one go the clock's last row comes within a second
#: of ``train_s``, which starts earlier; a process that stopped and another that resumed leave a gap of
#: minutes.
RESUMED_SLACK_S = 30.0


@dataclass
class Run:
    """One job of a sweep: its directory, the config it ran with, and its metrics or its error."""

    path: Path
    config: dict[str, Any] = field(default_factory=dict)
    overrides: list[str] = field(default_factory=list)
    choices: dict[str, str] = field(default_factory=dict)
    metrics: dict[str, Any] | None = None
    error: dict[str, Any] | None = None
    #: ``resolved_config.yaml`` (the composed config the run ran with), None where it has none
    resolved: dict[str, Any] | None = None

    @property
    def status(self) -> str:
        """`ok` (complete metrics.json), `failed` (error.json) or `incomplete` (neither)."""
        if self.metrics is not None:
            return "ok"
        return "failed" if self.error is not None else "incomplete"

    def _get(self, key: str, default: Any = None) -> Any:
        if self.metrics is not None and key in self.metrics:
            return self.metrics[key]
        return self.config.get(key, default)

    @property
    def experiment(self) -> str:
        return str(self._get("experiment", "?"))

    @property
    def budget(self) -> float | None:
        value = self._get("budget")
        return None if value is None else float(value)

    @property
    def seed(self) -> int | None:
        """The seed the job trained from (config `seed`; run.py seeds weights, crops and sampling with it)."""
        value = self._get("seed")
        try:
            return None if value is None else int(value)
        except (TypeError, ValueError):
            return None

    @property
    def sweep(self) -> str:
        """The sweep the job belongs to (`sweep_name`, from `sweeps/<name>.yaml`), else its grandparent."""
        name = self.config.get("sweep_name")
        return str(name) if name else self.path.parent.parent.name

    @property
    def transfer(self) -> dict[str, Any] | None:
        """The transfer settings of a transfer job (metrics.json `transfer`, else its config's `transfer`
        block with `init_from` set, or a job of sweeps/transfer.yaml); None for ordinary jobs."""
        value = self.metrics.get("transfer") if self.metrics is not None else None
        if isinstance(value, dict) and value:
            return value
        t = self.config.get("transfer")
        t = t if isinstance(t, dict) else {}
        if t.get("init_from") or self.config.get("sweep_name") == "transfer":
            data = self.config.get("data", {})
            scenes = data.get("transfer_scenes") or data.get("test_scenes") or []
            epochs = int(t.get("finetune_epochs") or 0)
            return {
                "scene": ", ".join(map(str, scenes)) if isinstance(scenes, list) else str(scenes),
                "finetune": epochs > 0,
                "finetune_epochs": epochs,
            }
        return None

    @property
    def data_profile(self) -> str:
        profile = self._get("data_profile") or self.choices.get("data")
        return str(profile) if profile else "?"

    @property
    def capacity_profile(self) -> str:
        """The capacity profile the job ran with (``metrics.json``, else Hydra's choice), ``?`` unrecorded."""
        profile = self._get("capacity_profile") or self.choices.get("capacity")
        return str(profile) if profile else "?"

    @property
    def data_settings(self) -> dict[str, Any] | None:
        """What determined the job's data (``metrics.json`` ``data_settings``), None where unrecorded."""
        value = self.metrics.get("data_settings") if self.metrics is not None else None
        return value if isinstance(value, dict) else None

    @property
    def method_switches(self) -> dict[str, bool]:
        """The component switches (docs/method.md) this job ran with, from its config."""
        method = self.config.get("method", {})
        return {k: bool(method[k]) for k in ("UN", "AS", "KP", "PP", "FG", "SA") if k in method}

    def _csv(self, name: str) -> pd.DataFrame | None:
        """A CSV file of the run directory, or None when absent or unreadable."""
        path = self.path / name
        if not path.is_file():
            return None
        try:
            return pd.read_csv(path)
        except (OSError, ValueError):
            return None

    @cached_property
    def frames(self) -> pd.DataFrame | None:
        """frames.csv (scene, frame, psnr, ...), or None when absent or unreadable."""
        return self._csv("frames.csv")

    @cached_property
    def curve(self) -> pd.DataFrame | None:
        """curve.csv (step, seconds, val_psnr, ... per validation; mcd.lit.budget), or None."""
        return self._csv("curve.csv")

    @cached_property
    def segments(self) -> list[dict[str, Any]]:
        """Which code trained which steps (metrics.json ``segments``, mcd/lit/segments.py), oldest first.

        A run from before those records that was nevertheless resumed shows it in ``curve.csv``, whose clock
        goes on across processes: when its last ``seconds`` exceed the finishing process's ``train_s`` by
        more than :data:`RESUMED_SLACK_S`, the earlier processes stand as one segment whose ``commit`` and
        steps are null and whose ``seconds`` is that excess."""
        if self.metrics is None:
            return []
        recorded = self.metrics.get("segments")
        if isinstance(recorded, list):
            return recorded
        curve, train_s = self.curve, self.metrics.get("train_s")
        if curve is None or curve.empty or "seconds" not in curve or not train_s:
            return []
        earlier = float(pd.to_numeric(curve["seconds"], errors="coerce").iloc[-1]) - float(train_s)
        if not earlier > RESUMED_SLACK_S:  # also NaN: a clock that is not a number says nothing
            return []
        last = {"commit": self.metrics.get("commit"), "dirty": self.metrics.get("dirty"), "start_step": None,
                "end_step": self.metrics.get("train_steps"), "seconds": float(train_s)}
        return [{"commit": None, "dirty": None, "start_step": 0, "end_step": None, "seconds": earlier}, last]

    @property
    def code(self) -> str:
        """The code that trained the run: the short commit of each of its :attr:`segments`, oldest first,
        ``+``-joined without repeats (``*`` after a dirty tree's, ``?`` for one not recorded), or the record's
        ``commit`` where it has no segments; ``?`` where nothing says. Two runs of different code may differ
        by more than their seeds do: a change of numerics gives another trajectory from the same seed."""
        def short(commit: Any, dirty: Any) -> str:
            return "?" if not commit else str(commit)[:7] + ("*" if dirty else "")
        names = [short(s.get("commit"), s.get("dirty")) for s in self.segments] or (
            [short(self.metrics.get("commit"), self.metrics.get("dirty"))] if self.metrics else ["?"])
        return "+".join(dict.fromkeys(names))

    @property
    def corrupt(self) -> str | None:
        """What is damaged in the run's records (a corrupt ``metrics.json``), else None."""
        return None if self.error is None else self.error.get("corrupt")

    @property
    def error_message(self) -> str:
        """One line naming what went wrong (for failed and incomplete jobs)."""
        if self.error is not None:
            msg = str(self.error.get("error") or self.error.get("message") or "see error.json")
            return msg.strip().splitlines()[0] if msg.strip() else "see error.json"
        if self.status == "incomplete":
            return "no metrics.json and no error.json: the job was killed or is still running"
        return ""


#: The plausible range of each score a run records (``mcd.core.metrics``): PSNR of display images in [0, the
#cap], : SSIM in [-1, 1], FLIP in [0, 1], errors at least 0. A score outside it is damage, not a result.
SCORE_RANGES = {
    **{k: (0.0, PSNR_CAP_DB) for k in ("psnr", "input_psnr", "tpsnr", "input_tpsnr")},
    **{k: (-1.0, 1.0) for k in ("ssim", "input_ssim")},
    **{k: (0.0, 1.0) for k in ("flip", "input_flip")},
    **{k: (0.0, math.inf) for k in ("rmse", "input_rmse", "lt")},
}
#: The columns every ``frames.csv`` has (``mcd.lit.test_recorder``).
FRAMES_COLUMNS = ("scene", "frame", "psnr")


def metrics_problem(path: Path) -> str | None:
    """What is wrong with the ``metrics.json`` at ``path`` (None: absent or sound): not readable JSON, not an
    object, or a score (``mcd.core.metrics.FRAME_METRICS``) that is not a number or null (``"psnr": "NaN"``),
    or one outside its range (:data:`SCORE_RANGES`: ``"psnr": 1e308``, ``"ssim": -5``).
    mcd.run writes it atomically (mcd/lit/run_record.py), so a damaged one is not a run still writing it."""
    if not path.exists():
        return None
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as err:
        return f"{path} is corrupt (not readable JSON: {err})"
    if not isinstance(data, dict):
        return f"{path} is corrupt (a JSON {type(data).__name__}, not an object)"
    bad = [f"{k}={data[k]!r}" for k in FRAME_METRICS if k in data and not _is_score(data[k])]
    if bad:
        return f"{path} is corrupt (not a number: {', '.join(bad)})"
    out = [f"{k}={data[k]!r} outside [{lo:g}, {hi:g}]" for k, (lo, hi) in SCORE_RANGES.items()
           if data.get(k) is not None and not lo <= data[k] <= hi]
    if out:
        return f"{path} is corrupt (a score out of range: {', '.join(out)})"
    shape = record_shape_problems(data)
    if shape:
        return f"{path} is corrupt (a field of another type: {', '.join(shape)})"
    absurd = absurd_numbers(data)
    if absurd:
        return f"{path} is corrupt (a number no run records: {', '.join(absurd)})"
    return None


#: The largest magnitude of a number a run records: its scores and statistics are float32 tensors' (and
#: its counts and seeds far smaller). A larger finite one (``"rmse": 1e300``) is damage, and printed in a
#: table it filled the cell with 301 digits.
RECORD_NUMBER_MAX = 3.4028234663852886e38
#: The largest number of seconds a run records (``wall_s``, ``train_s``, a segment's ``seconds``, ...): about
#: 31 years.
RECORD_SECONDS_MAX = 1e9


def absurd_numbers(data: object, where: str = "") -> list[str]:
    """The numbers of a run record (``metrics.json``, ``edges.json``; nested objects and lists too) that no
    run writes: a magnitude above :data:`RECORD_NUMBER_MAX` (an integer: above int64's, which the tables'
    columns hold), or seconds (a key ending in ``_s`` or named
    ``seconds``) outside [0, :data:`RECORD_SECONDS_MAX`]; each as ``key=value``, its path dotted."""
    if isinstance(data, dict):
        return [bad for k, v in data.items()
                for bad in absurd_numbers(v, f"{where}.{k}" if where else str(k))]
    if isinstance(data, list):
        return [bad for i, v in enumerate(data) for bad in absurd_numbers(v, f"{where}[{i}]")]
    if isinstance(data, bool) or not isinstance(data, int | float):
        return []
    name = where.rsplit(".", 1)[-1]
    seconds = name.endswith("_s") or name == "seconds"
    value = f"{data:.4g}" if isinstance(data, float) or abs(data) > 10**12 else str(data)
    too_large = abs(data) >= 2**63 if isinstance(data, int) else abs(data) > RECORD_NUMBER_MAX
    if too_large or (seconds and not 0 <= data <= RECORD_SECONDS_MAX):
        return [f"{where}={value}"]
    return []


#: The type of each ``metrics.json`` field (``mcd.lit.run_record.RunRecord``'s), by which a report reads it.
RECORD_TYPES = typing.get_type_hints(RunRecord)
#: The fields of one training segment (``metrics.json`` ``segments``, mcd/lit/segments.py) a report reads.
SEGMENT_TYPES = {"commit": str | None, "dirty": bool | None, "device": str | None, "precision": str | None,
                 "start_step": int | None, "end_step": int | None, "seconds": float | None}
#: What a report reads from a run's config (``.hydra/config.yaml``, ``resolved_config.yaml``, or an
#: ``error.json``'s ``config``), with its type; a section that is absent is not checked.
CONFIG_TYPES = {"experiment": str, "budget": float, "seed": int, "sweep_name": str | None,
                "data": dict, "method": dict, "transfer": dict | None, "train": dict}
CONFIG_SECTION_TYPES = {"data": {"width": int, "height": int, "train_scenes": list | None,
                                 "test_scenes": list | None, "transfer_scenes": list | None},
                        "transfer": {"finetune_epochs": int | None},
                        "train": {"max_steps": int | None}}


def _fits(value: object, hint: object) -> bool:
    """Whether a JSON or YAML value is of the type ``hint`` (an annotation of :data:`RECORD_TYPES` and the
    tables above): ``float`` a finite number (or null, how NaN is written), ``int`` an integer, never a bool;
    a generic (``dict[str, Any]``) its container."""
    if hint is typing.Any:
        return True
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        return any(_fits(value, h) for h in typing.get_args(hint))
    if hint is type(None):
        return value is None
    hint = typing.get_origin(hint) or hint
    if isinstance(value, bool):
        return hint is bool
    if hint is float:
        return value is None or (isinstance(value, int | float) and math.isfinite(value))
    return isinstance(value, hint)  # type: ignore[arg-type]


def _mismatches(data: dict[str, Any], kinds: dict[str, Any], where: str = "") -> list[str]:
    return [f"{where}{k}={data[k]!r}" for k, hint in kinds.items() if k in data and not _fits(data[k], hint)]


def record_shape_problems(data: dict[str, Any]) -> list[str]:
    """The fields of a ``metrics.json`` object whose value is not of its type (:data:`RECORD_TYPES`, the
    model metrics numbers or null, each ``segments`` entry as :data:`SEGMENT_TYPES`, ``per_scene`` scores
    numbers or null): a report reads each as that type, and one of another (``"budget": "abc"``) ended the
    whole report in a traceback."""
    bad = _mismatches(data, {k: v for k, v in RECORD_TYPES.items() if k != "scores"})
    bad += _mismatches(data, dict.fromkeys(MODEL_METRICS, float | None))
    for i, seg in enumerate(data.get("segments") or [] if isinstance(data.get("segments"), list) else []):
        bad += ([f"segments[{i}]={seg!r}"] if not isinstance(seg, dict)
                else _mismatches(seg, SEGMENT_TYPES, f"segments[{i}]."))
    per_scene = data.get("per_scene") if isinstance(data.get("per_scene"), dict) else {}
    for scene, scores in per_scene.items():
        bad += ([f"per_scene.{scene}={scores!r}"] if not isinstance(scores, dict)
                else _mismatches(scores, dict.fromkeys(scores, float | None), f"per_scene.{scene}."))
    return bad


def config_problems(config: object) -> list[str]:
    """What a report reads from a run's config that is not of its type (:data:`CONFIG_TYPES`,
    :data:`CONFIG_SECTION_TYPES`): ``method: 5`` or ``data: x`` ended the whole report in a traceback."""
    if not isinstance(config, dict):
        return [f"a {type(config).__name__}, not a mapping"]
    bad = _mismatches(config, CONFIG_TYPES)
    for section, kinds in CONFIG_SECTION_TYPES.items():
        if isinstance(config.get(section), dict):
            bad += _mismatches(config[section], kinds, f"{section}.")
    for key in RULED_KEYS:  # in range: the rule mcd.run checks them by before any work
        section, _, name = key.rpartition(".")
        part = config.get(section) if section else config
        if isinstance(part, dict) and name in part and not bad:
            value = part[name]
            try:
                checked(key, value)
            except ConfigError as err:
                bad.append(str(err))
            else:
                bad += absurd_numbers(value, key)
    return bad


#: The config keys a report computes with (the scaling report's steps, the frame size of its timings) that
#: have a rule in :data:`mcd.core.config_rules.RULES`: a record outside it (``train.max_steps: -5`` made a
#: scale point of -5 steps; ``1e50`` ended the scaling report in a traceback half written) is no run's.
RULED_KEYS = ("seed", "train.max_steps", "data.width", "data.height", "transfer.finetune_epochs")


def read_table(path: Path, columns: tuple[str, ...]) -> tuple[pd.DataFrame | None, str | None]:
    """``path`` read as a CSV that has ``columns``: ``(table, None)``, or ``(None, what is wrong)`` (not a
    readable CSV, or the columns it lacks) for the caller to name with its file or flag."""
    try:
        df = pd.read_csv(path)
    except (OSError, ValueError) as err:
        return None, f"not a readable CSV: {type(err).__name__}"
    missing = [c for c in columns if c not in df.columns]
    return (None, f"no column {', '.join(missing)}") if missing else (df, None)


def frames_problem(path: Path) -> str | None:
    """What is wrong with the ``frames.csv`` at ``path`` (None: absent or sound): not a readable CSV, without
    the columns :data:`FRAMES_COLUMNS`, with a PSNR that is not a number in its range, or with a scene's frame
    given twice (no run writes one twice: the copy was a second point of the per-frame plot and tables)."""
    if not path.exists():
        return None
    df, why = read_table(path, FRAMES_COLUMNS)
    if df is None:
        return f"{path} is corrupt ({why})"
    if df.empty:  # every run tests at least one frame: its run was left out of the per-frame plots unnamed
        return f"{path} is corrupt (its header only, no frame)"
    psnr = pd.to_numeric(df["psnr"], errors="coerce")
    lo, hi = SCORE_RANGES["psnr"]
    if not psnr.between(lo, hi).all():
        return f"{path} is corrupt (a psnr that is not a number in [{lo:g}, {hi:g}])"
    for col in ("frame", *SCORE_RANGES):  # read as numbers (the viewer's metrics, the per-frame plots)
        if col in df.columns and (pd.to_numeric(df[col], errors="coerce").isna() & df[col].notna()).any():
            return f"{path} is corrupt (a {col} that is not a number)"
    for col, (lo, hi) in SCORE_RANGES.items():  # in range, as metrics.json's (an empty cell: no such score)
        values = pd.to_numeric(df[col], errors="coerce") if col in df.columns else pd.Series([], dtype=float)
        hi = min(hi, RECORD_NUMBER_MAX)
        if (values.notna() & ~values.between(lo, hi)).any():
            return f"{path} is corrupt (a {col} outside [{lo:g}, {hi:g}])"
    unsafe = sorted({str(s) for s in df["scene"] if not SAFE_NAME.fullmatch(str(s))})
    if unsafe:  # a scene names the report's per-frame plot: "../x" wrote outside the report folder
        return (f"{path} is corrupt (a scene that is not a plain name: {unsafe[0]!r}; scenes are letters, "
                "digits, '_', '-', '.', and name the report's files)")
    if (pd.to_numeric(df["frame"], errors="coerce") < 0).any():
        return f"{path} is corrupt (a negative frame: a test frame's index counts from 0)"
    twice = df[df.duplicated(["scene", "frame"])]
    if not twice.empty:
        return f"{path} is corrupt ({twice['scene'].iloc[0]} frame {twice['frame'].iloc[0]} is given twice)"
    return None


def _is_score(value: object) -> bool:
    """A number (JSON null stands for NaN in a run record)."""
    return value is None or (isinstance(value, int | float) and not isinstance(value, bool))


def _read_yaml(path: Path, read) -> tuple[Any, str | None]:
    """``read(path)`` of a run's Hydra record, or ``(None, the problem naming the file)`` when it is not
    readable YAML of the expected shape."""
    try:
        return read(path), None
    except Exception as err:  # yaml, OmegaConf and shape errors alike: the run's damage, not the report's
        return None, f"{path} is corrupt (not a readable Hydra record: {type(err).__name__})"


def _choices(hydra_file: Path) -> Any:
    """The config groups' choices Hydra recorded in ``hydra_file`` (None without one)."""
    if not hydra_file.is_file():
        return None
    return OmegaConf.select(OmegaConf.load(hydra_file), "hydra.runtime.choices", default=None)


#: What a run directory's records are: every file the report reads apart from ``samples/`` (a report keeps
#: a copy of each, mcd.reporting.records).
RECORD_FILES = (
    "metrics.json",
    EDGES_FILE,
    "error.json",
    "frames.csv",
    "curve.csv",
    "resolved_config.yaml",
    ".hydra/config.yaml",
    ".hydra/overrides.yaml",
    ".hydra/hydra.yaml",
)


def load_run(path: Path) -> Run:
    """Read one run directory. A corrupt record (``metrics.json``: :func:`metrics_problem`; ``frames.csv``:
    :func:`frames_problem`; a ``.hydra/`` file that is not readable YAML) makes the job failed, the file
    named in its error; one without ``psnr`` is incomplete (mcd.run reruns it). A record that is there but
    is not a regular file (a FIFO, on which reading waited for ever; a device; a folder) fails the job
    before anything of it is read."""
    odd = next((path / n for n in RECORD_FILES if (path / n).exists() and not (path / n).is_file()), None)
    if odd is not None:
        why = f"{odd} is corrupt (not a regular file)"
        return Run(path=path, error={"error": why, "corrupt": why})
    problem = metrics_problem(path / "metrics.json") or frames_problem(path / "frames.csv")
    metrics = None if problem else _load_json(path / "metrics.json")
    if metrics is not None and "psnr" not in metrics:
        metrics = None  # an incomplete metrics.json is not a finished run (mcd.run reruns it)
    edges = _load_json(path / EDGES_FILE)  # measured after the run by tools/edge_effect.py
    absurd = absurd_numbers(edges or {})  # its numbers join the tables
    if absurd:
        problem = problem or f"{path / EDGES_FILE} is corrupt (a number no run records: {', '.join(absurd)})"
        metrics = None
    if metrics is not None and edges is not None and edges.get("checkpoint") == metrics.get("checkpoint"):
        metrics = {**metrics, **{k: edges.get(k) for k in ("edge_effect", *MAP_KEYS)}}
    error = _load_json(path / "error.json")
    if error is None and (path / "error.json").exists():
        error = {"error": f"{path / 'error.json'} exists but is not readable JSON"}
    overrides_file = path / ".hydra" / "overrides.yaml"
    overrides, bad = _read_yaml(overrides_file, lambda f: [str(o) for o in OmegaConf.load(f)]
                                if f.is_file() else [])
    problem = problem or bad
    if not overrides and error is not None and isinstance(error.get("overrides"), list):
        overrides = [str(o) for o in error["overrides"]]
    config, bad = _read_yaml(path / ".hydra" / "config.yaml", lambda f: dict(_load_yaml(f)))
    problem = problem or bad
    source = path / ".hydra" / "config.yaml"
    if not config and error is not None and isinstance(error.get("config"), dict):
        config, source = error["config"], path / "error.json"
    config = config or {}
    resolved_file = path / "resolved_config.yaml"
    resolved, bad = _read_yaml(resolved_file, lambda f: OmegaConf.to_container(OmegaConf.load(f),
                                                                               resolve=False)
                               if f.is_file() else None)
    problem = problem or bad
    for what, cfg in ((source, config), (resolved_file, resolved)):
        shape = config_problems(cfg) if cfg is not None else []
        if shape:
            problem = problem or (f"{what} is corrupt (a value of another type: "
                                  f"{', '.join(shape)})")
    # what the failed run's row shows is read from its config: only the parts of their types stay
    config = {k: v for k, v in config.items() if not config_problems({k: v})}
    choices, bad = _read_yaml(path / ".hydra" / "hydra.yaml", _choices)
    problem = problem or bad
    choices = {str(k): str(v) for k, v in (choices or {}).items() if not str(k).startswith("hydra")}
    if problem:
        metrics, error = None, {**(error or {}), "error": problem, "corrupt": problem}
    return Run(path=path, config=config, overrides=overrides or [], choices=choices, metrics=metrics,
               error=error, resolved=resolved if isinstance(resolved, dict) and not problem else None)


def _is_run_dir(path: Path) -> bool:
    return (
        (path / "metrics.json").is_file()
        or (path / "error.json").is_file()
        or (path / ".hydra" / "config.yaml").is_file()
    )


class NoRunsError(FileNotFoundError):
    """A folder given to report on is missing or holds no run directory (``mcd.report``: one line)."""


def find_runs(roots: list[Path]) -> list[Run]:
    """Every run directory under `roots` (each a multirun dir, a sweep dir or one run dir), sorted by path;
    NoRunsError naming a root that does not exist."""
    found: set[Path] = set()
    for root in roots:
        if not root.exists():
            raise NoRunsError(f"{root}: no such directory (pass multirun dirs written by mcd.run -m)")
        candidates = [root, *(p for p in root.rglob("*") if p.is_dir() and p.name != ".hydra")]
        found.update(p.resolve() for p in candidates if _is_run_dir(p))
    return [load_run(p) for p in sorted(found)]


@dataclass
class Sweep:
    """A sweep directory and the command that launched it (from Hydra's multirun.yaml)."""

    path: Path
    name: str
    command: str
    data_profile: str


def _widened(task: list[str], sweep_dir: Path) -> list[str]:
    """``task`` (a sweep's command-line overrides from its multirun.yaml) with each key its jobs ran with
    several values of widened to all of them. A sweep split over processes that share one directory keeps
    only the last process's command in multirun.yaml; widened, the command runs every job the directory
    holds. That process may have run no job at all (a rerun whose jobs were finished, and skipped), so a
    key no job ran with is left out, and a value no job ran with is replaced by those they ran with (a
    skipped rerun with ``capacity=paper`` named that in the report of runs trained with ``capacity=cpu``)."""
    seen: dict[str, list[str]] = {}
    for overrides in sorted(p for p in sweep_dir.glob("*/.hydra/overrides.yaml") if p.is_file()):
        # as typed: an override like transfer.init_from=.../${experiment}_spp4 stays unresolved
        items, _ = _read_yaml(overrides, lambda f: list(OmegaConf.to_container(OmegaConf.load(f),
                                                                                  resolve=False)))
        for item in items or []:  # a damaged one fails its job (load_run), and adds nothing here
            key, _, value = str(item).partition("=")
            values = seen.setdefault(key, [])
            if value not in values:
                values.append(value)
    out = []
    for item in task:
        key, sep, value = item.partition("=")
        ran = seen.get(key, [])
        if seen and not ran:  # only a process that ran no job had it
            continue
        if sep and ran and value not in ran and not set(value.split(",")) & set(ran):
            value = ",".join(ran)
        elif sep and len(ran) > 1:
            listed = value.split(",")
            value = ",".join([*listed, *sorted(v for v in ran if v not in listed)])
        out.append(f"{key}{sep}{value}")
    return out


def find_sweeps(roots: list[Path]) -> list[Sweep]:
    """The sweep directories (holding multirun.yaml) under or above `roots`."""
    files: set[Path] = set()
    for root in roots:
        files.update(p.resolve() for p in root.rglob("multirun.yaml") if p.is_file())
        files.update(
            p.resolve() for p in [root / "multirun.yaml", root.parent / "multirun.yaml"] if p.is_file()
        )
    sweeps = []
    for f in sorted(files):
        try:
            cfg = OmegaConf.load(f)
        except (yaml.YAMLError, ValueError) as err:  # e.g. two processes wrote it at once
            log.warning("%s: unreadable (%s); the sweep's command is left out of the report, its runs are "
                        "not (each run directory keeps its own .hydra/)", f, type(err).__name__)
            continue
        node = OmegaConf.select(cfg, "hydra.overrides.task", default=None)
        # as typed: an override like transfer.init_from=.../${experiment}_spp4 stays unresolved
        task = OmegaConf.to_container(node, resolve=False) if node is not None else []
        choices = OmegaConf.select(cfg, "hydra.runtime.choices", default={}) or {}
        name = OmegaConf.select(cfg, "sweep_name", default=None) or f.parent.parent.name
        sweeps.append(
            Sweep(
                path=f.parent,
                name=str(name),
                command="python -m mcd.run -m " + " ".join(_widened(list(map(str, task)), f.parent)),
                data_profile=str(choices.get("data", "?")),
            )
        )
    return sweeps
