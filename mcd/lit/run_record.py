"""The run record: what ``python -m mcd.run`` writes to ``metrics.json`` (docs/architecture.md, "Run
directory").

:class:`RunRecord` owns the keys of ``metrics.json``: one field per key, written in field order, the test
averages first as top-level keys named as in ``mcd.core.metrics`` (``psnr`` ... ``input_rmse``, then
``kp_identity``, ``kp_index_std``, null for a model without a kernel map). NaN and infinity are written as
``null`` (JSON has no NaN). The reports (``mcd.reporting``) read these keys. A sweep skips a job whose
``metrics.json`` holds every key of :data:`REQUIRED_KEYS` (:func:`is_complete`) when it is the same job
(:func:`job_identity`; another job's is an error, :func:`check_same_job`). A directory holding an
interrupted run of another job is refused too (:func:`claim_run_dir`, ``job.json``).
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf

from mcd.core.atomic_write import atomic_write_json
from mcd.core.metrics import FRAME_METRICS, MODEL_METRICS, PAPER_METRICS
from mcd.data.store import store_settings
from mcd.models.switches import switch_row

#: Keys a finished run's ``metrics.json`` must hold (a sweep skips jobs that have them all); runs from before
#: ``ADDED_METRICS`` lack those and still count as finished.
REQUIRED_KEYS = (*PAPER_METRICS, "macs_g", "params_m", "experiment", "method", "budget", "data_profile",
                 "commit", "device", "wall_s", "per_scene", "perceptual_loss")
#: Methods whose ``method.UN..SA`` switches mean something (the component study; ``unet`` is row A).
SWITCHED_METHODS = ("two_stage", "unet")


@dataclasses.dataclass
class RunRecord:
    """One run's ``metrics.json`` (see the module docstring); :meth:`write` saves it."""

    #: Test averages over scenes (``mcd.core.metrics.aggregate``) of ``FRAME_METRICS`` and ``MODEL_METRICS``.
    scores: dict[str, float | None]
    macs_g: float | None  # 1080p GMACs (mcd.models.complexity); null where FlopCounterMode cannot count them
    params_m: float | None  # millions of parameters (older records: null for OIDN)
    experiment: str
    method: dict[str, Any]  # the resolved ``method`` config
    switches: str | None  # ``method.UN..SA`` as 0/1 (mcd.models.switches.switch_row); null for baselines
    budget: int  # average samples per pixel
    seed: int
    data_profile: str | None  # the Hydra choices of the config groups data, capacity, train
    capacity_profile: str | None
    train_profile: str | None
    #: what determines the data (mcd.data.store.store_settings), part of the job's identity
    data_settings: dict[str, Any]
    per_scene: dict[str, dict[str, float | None]]  # per-scene averages of every score
    scenes_test: list[str]
    test_frames: dict[str, int]  # frames tested per scene
    perceptual_loss: dict[str, Any]  # whether L_p was on, and why not (mcd.losses.vgg.PerceptualStatus)
    commit: str  # the code's commit, "unknown" outside git (mcd.run.git_commit)
    dirty: bool | None  # whether the working tree differed from it
    device: str  # GPU name, or CPU model and threads (mcd.run.device_name)
    precision: str  # the Lightning precision the run trained and tested in
    torch: str  # torch version
    allocator: str  # the process's allocator setting (mcd/core/allocator.py; older records lack the key)
    config: str  # path of resolved_config.yaml
    #: the store's report of what it rendered and reused; ``replaced_by_0``: the NaN/Inf/negative values
    #: replaced by 0 in the frames the run read (mcd.data.store.StoreReader.replaced_counts); with
    #: ``data.train_store.format=array``, ``train_store``: the pack's report (``clamped_total``: values
    #: clamped to the float16 range in the packed frames)
    data: dict[str, Any]
    trained: bool
    transfer: dict[str, Any] | None  # the transfer settings (mcd.lit.transfer); null for an ordinary run
    checkpoint: str | None  # the checkpoint tested; null for a method tested as built
    best_val_psnr: float | None
    train_steps: int
    stop_reason: str  # why training ended (mcd.lit.budget.stop_reason)
    #: per process that trained, oldest first: commit, dirty, device, start_step, end_step, seconds
    #: (mcd/lit/segments.py); one for a run trained in one go, several for a resumed one, [] if untrained
    segments: list[dict[str, Any]]
    epochs: int
    data_s: float  # seconds spent rendering or checking the store, training, testing, and in all
    train_s: float
    test_s: float
    wall_s: float

    @staticmethod
    def scores_of(averages: dict[str, object]) -> dict[str, float | None]:
        """The :attr:`scores` of a test's averages (``mcd.core.metrics.aggregate``): every ``FRAME_METRICS``
        key, and each ``MODEL_METRICS`` key, ``None`` where the model has no such statistic."""
        return {**{k: averages[k] for k in FRAME_METRICS},  # type: ignore[misc]
                **{k: averages.get(k) for k in MODEL_METRICS}}  # type: ignore[misc]

    def as_dict(self) -> dict[str, Any]:
        """The JSON object of ``metrics.json``."""
        fields = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "scores"}
        return {k: _json_safe(v) for k, v in {**self.scores, **fields}.items()}

    def write(self, run_dir: Path) -> dict[str, Any]:
        """Write ``run_dir/metrics.json`` atomically (:mod:`mcd.core.atomic_write`: a killed write
        leaves no half file under that name, so a damaged one is damage, mcd.reporting.runs); returns what
        it wrote."""
        data = self.as_dict()
        atomic_write_json(run_dir / "metrics.json", data, indent=2)
        return data


def _json_safe(value: object) -> object:
    """NaN/inf become ``None`` (JSON has no NaN), also inside dicts."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    return value


def is_complete(path: Path) -> bool:
    """Whether ``path`` is a readable ``metrics.json`` holding every key of :data:`REQUIRED_KEYS`."""
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return False
    return isinstance(data, dict) and all(k in data for k in REQUIRED_KEYS)


def job_identity(cfg: DictConfig, choices: dict[str, str]) -> dict[str, object]:
    """What makes two runs the same job: the values a :class:`RunRecord` of ``cfg`` holds under these keys.

    ``data_settings`` is what determines the data (:func:`mcd.data.store.store_settings`: ``data.name``, the
    frames' size and count, the samples, the data seed, the exposure, the scene lists; and what each scene is
    made of, :func:`scene_settings`, as ``scenes.<name>.<key>``, so that a report does not put runs of other
    camera paths into one cell), so that a run is not resumed, or skipped as finished, on other data under the
    same profile; ``transfer`` the checkpoint a
    transfer starts from and its fine-tuning (:func:`mcd.lit.transfer.identity`). Settings a rerun may change
    without making it another job (epochs, capacity, ...) are left out (sweeps/_sweep_dirs.yaml: such a rerun
    goes to another ``sweep_tag``).
    """
    from mcd.lit.transfer import identity as transfer_identity

    return {"experiment": str(cfg.experiment), "budget": int(cfg.budget), "seed": int(cfg.seed),
            "data_profile": choices.get("data"), "data_settings": data_settings(cfg),
            "switches": switch_row(cfg.method) if cfg.method.name in SWITCHED_METHODS else None,
            "transfer": transfer_identity(cfg)}


def data_settings(cfg: DictConfig) -> dict[str, Any]:
    """``metrics.json`` ``data_settings``: :func:`mcd.data.store.store_settings` and each scene's
    :func:`scene_settings` without their ``data.`` prefix (``scenes.cbox.path.dolly``)."""
    scenes = {k.removeprefix("data."): v for k, v in scene_settings(cfg).items()}
    return {**store_settings(cfg.data), **scenes}


def job_record(cfg: DictConfig, choices: dict[str, str]) -> dict[str, Any]:
    """What ``job.json`` and each checkpoint (:class:`mcd.lit.segments.TrainingSegments`) record of the job
    that trains: its identity (:func:`job_identity`), split, scenes, training values and optimiser
    settings."""
    return {**job_identity(cfg, choices), "split": split_settings(cfg), "scenes": scene_settings(cfg),
            "values": value_settings(cfg), "optimiser": optimiser_settings(cfg),
            "training": training_settings(cfg)}


def check_recorded_job(recorded: dict[str, Any], cfg: DictConfig, choices: dict[str, str], where: Path,
                       what: str) -> None:
    """FileExistsError naming each key where ``recorded`` (a :func:`job_record`, from ``job.json`` or a
    checkpoint) differs from this job: ``where`` holds ``what`` (an interrupted run) of another job, split,
    scenes, precision or optimiser settings, which a resume would train further under another record."""
    _refuse_other_settings(recorded.get("scenes"), scene_settings(cfg), where, f"{what} of other scenes",
                           "its steps so far trained on frames of the old scenes, and a resume would train "
                           "and test on others under one record")  # first: data_settings holds them too
    _refuse_another_job(recorded, cfg, choices, where, what)
    checks = (
        ("split", split_settings(cfg), "of another split of the frames",
         "its steps so far trained on frames of the old split, which this one may test"),
        ("values", value_settings(cfg), "trained on values of another precision",
         "its steps so far read the frames at the old precision, and its record would name the new one"),
        ("optimiser", optimiser_settings(cfg), "trained with other optimiser settings", "its checkpoint "
         "carries the optimiser's and the schedule's state, so a resume keeps training at the old rate"),
        ("training", training_settings(cfg), "trained with other training settings", "its steps so far "
         "trained under the old ones, and its records (resolved_config.yaml) would name the new ones only"))
    for section, mine, differs, why in checks:
        _refuse_other_settings(recorded.get(section), mine, where, f"{what} {differs}", why)


def _flat(identity: dict[str, Any]) -> dict[str, Any]:
    """``identity`` with ``data_settings`` spread into one ``data.<key>`` entry per setting (older records,
    without it, compare the other keys only), and ``transfer`` into ``transfer`` (whether the run is a
    transfer) and one ``transfer.<key>`` entry per key of :func:`mcd.lit.transfer.identity` (a finished run's
    ``metrics.json`` holds more under it; those are not compared)."""
    settings, transfer = identity.get("data_settings"), identity.get("transfer")
    flat = {k: v for k, v in identity.items() if k not in ("data_settings", "transfer")}
    if isinstance(settings, dict):
        flat.update({f"data.{k}": v for k, v in settings.items()})
    if "transfer" in identity:
        flat["transfer"] = transfer is not None
    if isinstance(transfer, dict):
        flat.update({f"transfer.{k}": transfer[k] for k in ("init_from", "finetune_epochs", "finetune_clips")
                     if k in transfer})
    return flat


def check_same_job(path: Path, cfg: DictConfig, choices: dict[str, str]) -> None:
    """FileExistsError if the finished ``metrics.json`` at ``path`` is another job's (it is not skipped), or
    its ``job.json`` records another split of the frames (:func:`split_settings`)."""
    try:
        recorded = json.loads((path.parent / JOB_FILE).read_text())
    except (OSError, ValueError):
        recorded = None
    if not isinstance(recorded, dict):
        recorded = {}
    # the scenes first: data_settings holds them too (where job.json is lost), named there as another job's
    _refuse_other_settings(recorded.get("scenes"), scene_settings(cfg), path.parent,
                           "a finished run of other scenes", "its scores are of frames of the old scenes")
    _refuse_another_job(json.loads(path.read_text()), cfg, choices, path.parent, "a finished run")
    _refuse_other_settings(recorded.get("split"), split_settings(cfg), path.parent,
                           "a finished run of another split of the frames",
                           "its scores are of other test frames")


#: The job identity (:func:`job_identity`) of the run that trains in a run directory, written before training.
JOB_FILE = "job.json"


def claim_run_dir(run_dir: Path, cfg: DictConfig, choices: dict[str, str],
                  checkpoint: tuple[Path, dict[str, Any] | None] | None = None) -> dict[str, Any]:
    """Record this job's identity in ``run_dir/job.json``, after refusing a directory that holds an
    interrupted run (``checkpoints/last.ckpt``, no ``metrics.json``) of another job: resuming it with another
    budget, seed, experiment, switches, data profile or data settings (another store) would test a checkpoint
    trained under the old settings and label it with the new ones (docs/reliability.md). FileExistsError names
    the keys that differ; a ``job.json`` that is not a JSON object is named too (ValueError). ``checkpoint``:
    the checkpoint training resumes from and the job record it holds (``mcd.lit.segments.recorded_job``),
    checked the same way, also where ``job.json`` is lost or the checkpoint is another directory's. Returns
    what it wrote (:func:`job_record`)."""
    path = run_dir / JOB_FILE
    if (run_dir / "checkpoints" / "last.ckpt").is_file() and path.is_file():
        try:
            recorded = json.loads(path.read_text())
        except ValueError as err:
            raise ValueError(f"{path}: not readable JSON ({err}); it records which job trained in "
                             f"{run_dir}: restore it, or give this run its own directory") from None
        if not isinstance(recorded, dict):
            raise ValueError(f"{path}: expected a JSON object of {sorted(job_identity(cfg, choices))}")
        check_recorded_job(recorded, cfg, choices, run_dir, "an interrupted run")
    if checkpoint is not None and checkpoint[1] is not None:
        check_recorded_job(checkpoint[1], cfg, choices, checkpoint[0], "steps")
    # the processes of a DDP run all write it
    record = job_record(cfg, choices)
    atomic_write_json(path, record, indent=2)
    return record


def split_settings(cfg: DictConfig) -> dict[str, float | int]:
    """The ``data.*`` settings that split each sequence into test, validation and training frames
    (:func:`mcd.data.splits.split_frames`). A resume under another split tested frames its first steps had
    trained on (``data.test_fraction`` 0.2, then 0.5: frame 9 of 20 trained, then tested), and a rerun under
    another was skipped as finished. Recorded in ``job.json`` beside the job's identity."""
    d = cfg.data
    return {"data.test_fraction": float(d.get("test_fraction", 0.2)), "data.val_clips": int(d.val_clips),
            "data.clip_len": int(d.clip_len)}


def scene_settings(cfg: DictConfig) -> dict[str, Any]:
    """What each scene of the run's lists is made of, beyond :func:`mcd.data.store.store_settings` (which
    names the scenes only): ``data.scenes.<name>.file_sha256`` and ``.reads_sha256`` (an XML scene's file and
    the meshes, textures and XML it reads, :func:`mcd.data.scenes.reads_digest`; ``None`` where the file is
    missing: the store names it), ``.source_sha256`` (a procedural scene's seed, room and generator),
    ``.path.<key>`` (the camera path) and ``.exposure``; a scene given by its file's path in a list gets the
    digests under the name it is registered by. The store renders again when one changes
    (:meth:`mcd.data.scenes.SceneSpec.source`), so a resume under another camera path, or of a scene file
    edited in place, trained the rest of its steps, and was tested, on other frames under one record, and a
    rerun was skipped as finished. Recorded in ``job.json`` beside the job's identity (docs/reliability.md,
    "Campaign fixes")."""
    from mcd.data.scenes import SceneSpec, path_scene_name

    entries = dict.fromkeys(str(n) for k in ("train_scenes", "transfer_scenes", "test_scenes")
                            for n in cfg.data.get(k) or [])
    scenes_dir = OmegaConf.select(cfg, "paths.scenes_dir", default=None)
    registered = cfg.data.get("scenes") or {}
    found: dict[str, Any] = {}
    for entry in entries:
        if entry.endswith(".xml"):  # given by its path (mcd.data.scenes.register_paths)
            file = Path(entry).expanduser().resolve()
            spec = SceneSpec(path_scene_name(file), "xml", file=file)
        elif entry in registered:
            spec = SceneSpec.from_cfg(entry, registered[entry], scenes_dir)
        else:  # not registered: the store names it
            continue
        key = f"data.scenes.{spec.name}"
        if spec.kind == "xml":
            found.update(_file_digests(key, spec.file))
        else:
            found[f"{key}.source_sha256"] = spec.source()["sha256"]
        if not entry.endswith(".xml"):
            found.update({f"{key}.path.{k}": v for k, v in sorted(spec.path.items())})
            found[f"{key}.exposure"] = spec.exposure
    return found


def _file_digests(key: str, file: Path | None) -> dict[str, str | None]:
    """``<key>.file_sha256`` and ``<key>.reads_sha256`` of an XML scene file (both ``None`` where missing)."""
    from mcd.data.scenes import file_sha256, reads_digest

    if file is None or not file.is_file():
        return {f"{key}.file_sha256": None, f"{key}.reads_sha256": None}
    return {f"{key}.file_sha256": file_sha256(file), f"{key}.reads_sha256": reads_digest(file)}


def value_settings(cfg: DictConfig) -> dict[str, str]:
    """The precision of the values training reads: ``data.train_store.dtype`` with the packed store
    (``data.train_store.format=array``), ``float32`` from the EXR files. A resume that switched to a float16
    pack trained the rest of its steps on rounded (and clamped) frames while its record named float16 only.
    Recorded in ``job.json``; a finished run rerun at another precision is skipped as before."""
    ts = cfg.data.get("train_store") or {}
    packed = str(ts.get("format", "exr")) == "array"
    return {"data.train_store.dtype": str(ts.get("dtype", "float32")) if packed else "float32"}


def optimiser_settings(cfg: DictConfig) -> dict[str, float]:
    """The ``train.*`` settings of the optimiser and its schedule (:meth:`mcd.lit.module.DenoiseModule
    .configure_optimizers`) that a resumed run cannot change: Lightning restores the optimiser's and the
    schedule's state from the checkpoint, so a resume with another ``train.lr`` trained at a mix of the two
    rates while its records named the new one. Recorded in ``job.json`` beside the job's identity."""
    return {f"train.{k}": float(cfg.train[k]) for k in ("lr", "lr_min", "weight_decay")}


#: ``train.*`` keys a resume may change: the budget, when to validate and stop, what to save, and speed.
BUDGET_KEYS = ("epochs", "max_steps", "max_minutes", "patience", "min_delta", "limit_train_batches",
               "val_every",
               "val_every_steps", "sample_frames", "channels_last", "compile")
#: ``method.*`` keys that act outside training only (docs/method.md "Output", "Frame edges").
TEST_TIME_KEYS = ("output_bound", "denoiser_margin")


def training_settings(cfg: DictConfig) -> dict[str, Any]:
    """What a training step does, beyond the optimiser (:func:`optimiser_settings`): ``train.*`` but the
    budget and logistics (:data:`BUDGET_KEYS`), ``loss.*``, ``method.*`` but :data:`TEST_TIME_KEYS`, and the
    training clips' ``data.train_crop``, ``data.train_crop_at_edge`` and ``data.augment.*``, and the
    validation's ``data.val_crop`` (the best checkpoint is picked by PSNRs measured at it), one flat key each.
    A resume with another crop, batch size or loss weight trained its last steps under the new values while
    ``resolved_config.yaml`` named them alone. Recorded in ``job.json`` and the checkpoints; a resume
    may still change the budget."""
    def flat(prefix: str, node: Any) -> dict[str, Any]:
        if isinstance(node, dict):
            return {k: v for key, value in node.items() for k, v in flat(f"{prefix}.{key}", value).items()}
        return {prefix: node}

    def plain(key: str) -> Any:
        node = OmegaConf.select(cfg, key, default=None)
        return OmegaConf.to_container(node, resolve=True) if isinstance(node, DictConfig) else node

    train = {k: v for k, v in (plain("train") or {}).items()
             if k not in BUDGET_KEYS and f"train.{k}" not in optimiser_settings(cfg)}
    method = {k: v for k, v in (plain("method") or {}).items() if k not in TEST_TIME_KEYS}
    found = {**flat("train", train), **flat("loss", plain("loss") or {}), **flat("method", method),
             **flat("data.augment", plain("data.augment") or {})}
    for key in ("data.train_crop", "data.train_crop_at_edge", "data.val_crop"):
        found[key] = plain(key)
    return found


def _refuse_other_settings(recorded: Any, mine: dict[str, Any], run_dir: Path, what: str, why: str) -> None:
    """FileExistsError naming each key of ``mine`` whose value differs from ``recorded`` (a section of the
    run's ``job.json``; one from before the section is not compared): ``run_dir`` holds ``what``, and
    ``why`` a rerun there cannot go on."""
    if not isinstance(recorded, dict):
        return
    differs = {k: (recorded[k], v) for k, v in mine.items() if k in recorded and recorded[k] != v}
    if differs:
        detail = "; ".join(f"{k}: {old!r} there, {new!r} here" for k, (old, new) in differs.items())
        raise FileExistsError(f"{run_dir} holds {what} ({detail}): {why}; run it with the old values, or "
                              "give this run its own directory (hydra.run.dir=<dir>, or sweep_tag=<tag> in a "
                              "sweep)")


def _refuse_another_job(recorded: dict[str, Any], cfg: DictConfig, choices: dict[str, str], run_dir: Path,
                        what: str) -> None:
    """FileExistsError naming each key of :func:`job_identity` (each ``data.<key>`` of its data settings)
    whose value in ``recorded`` differs."""
    recorded = _flat(recorded)
    differs = {k: (recorded[k], v) for k, v in _flat(job_identity(cfg, choices)).items()
               if k in recorded and recorded[k] != v}
    if differs:
        detail = "; ".join(f"{k}: {old!r} there, {new!r} here" for k, (old, new) in differs.items())
        raise FileExistsError(f"{run_dir} holds {what} of another job ({detail}); give this run its own "
                              "directory (hydra.run.dir=<dir>, or sweep_tag=<tag> in a sweep)")
