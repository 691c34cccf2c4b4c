"""Reading the on-disk benchmark store (docs/architecture.md, "The store"; docs/benchmark.md, "Data protocol";
docs/data.md, "Buffers, seeds, store").

Layout: ``<data_dir>/<profile>/<scene>/manifest.json`` and
``<data_dir>/<profile>/<scene>/<frame:04d>/<buffer>.exr`` (buffers: :mod:`mcd.data.buffers`).

:class:`StoreReader` reads the store: the manifest (render settings, cameras, exposure scale, and per file
spp, seed, byte size, SHA-256 and the NaN / Inf / negative counts the renderer produced), the frame count, and
:meth:`StoreReader.load`, which gives a buffer as every model sees it: checked against the manifest, colour
multiplied by the scene's exposure scale (``exposure: auto`` sets the mean of frame 0's reference to
``data.exposure_target``; recorded in the manifest), depth divided by the scene's ``depth_scale`` (median
first-hit distance of frame 0), then NaN/Inf (and negative values where they are not meaningful) replaced by 0
with one log line per file. The datamodule, ``mcd.bench`` and ``mcd.check_paths`` read through it;
:class:`mcd.data.store_builder.StoreBuilder` (a reader that also renders) writes the store.
"""

from __future__ import annotations

import json
import logging
import re
import shlex
from collections.abc import Iterable
from pathlib import Path
from typing import Any, Self

import numpy as np
from omegaconf import DictConfig, OmegaConf

from mcd.core.paths import check_folder_name
from mcd.core.paths import data_dir as resolve_data_dir
from mcd.core.paths import scenes_dir as resolve_scenes_dir
from mcd.data.buffers import CHANNELS, COLOUR_BUFFERS
from mcd.data.camera import Camera
from mcd.data.exposure import normalise
from mcd.data.exr import CorruptEXRError, read_exr, sha256
from mcd.data.scenes import SCENE_LISTS, SceneSpec, path_scene_name

log = logging.getLogger(__name__)

#: Command-line overrides that shape the store (``data=..``, ``data.*``, ``+scene@data.scenes.*``,
#: ``paths.*``).
STORE_OVERRIDE = re.compile(r"[+~]*(data[.=]|scene@data\.|paths\.)")
_MISSING = object()


#: Keys of ``data`` that shape the store's files (besides ``name`` and the scene lists,
#: :func:`store_settings`): the frames' size, the camera path's frames, the samples, the data seed, the
#: exposure.
STORE_KEYS = ("width", "height", "segments", "frames_per_segment", "ref_spp", "ref_quality.target_db",
              "ref_quality.max_spp", "gbuffer_spp", "max_depth", "seed", "exposure_target")


def store_settings(data_cfg: DictConfig) -> dict[str, object]:
    """What determines a profile's data: ``name``, each :data:`STORE_KEYS` key the config has, and the scene
    lists (``train_scenes``, ``transfer_scenes``, ``test_scenes``), a scene given as a file named as
    :func:`mcd.data.scenes.register_paths` names it, so the settings read the same before and after."""
    found = {k: OmegaConf.select(data_cfg, k, default=_MISSING) for k in STORE_KEYS}
    scenes = {k: [path_scene_name(Path(str(e)).expanduser().resolve()) if str(e).endswith(".xml") else str(e)
                  for e in data_cfg.get(k) or []] for k in SCENE_LISTS}
    return {"name": str(data_cfg.name), **{k: v for k, v in found.items() if v is not _MISSING}, **scenes}


class CorruptManifestError(RuntimeError):
    """A scene's ``manifest.json`` is not readable JSON; the message names it and the command that fixes
    it."""


def check_name(name: str, key: str) -> str:
    """``name`` if it is a single safe folder name (:func:`mcd.core.paths.check_folder_name`), else ValueError
    naming ``key``.

    Profile and scene names become folders of the store; ``..`` or ``/`` would write outside
    ``paths.data_dir``.
    """
    return check_folder_name(name, key, "the store writes <paths.data_dir>/<data.name>/<scene>/")


class StoreReplacedError(RuntimeError):
    """A store's scene was rendered again with other settings while a process read it (the message names
    the settings that changed and the fix)."""


def manifest_problem(man: object) -> str | None:
    """What makes ``man`` (a parsed ``manifest.json``) unusable, or None: the schema the store reads, checked
    on read so that damage is named with its fix instead of failing later (docs/data.md, "The store"):
    ``files`` an object of ``"<frame>/<buffer>.exr"`` entries, each an object with an integer ``bytes`` and a
    string ``sha256``; ``cameras`` a list of objects; ``exposure`` and ``depth_scale`` numbers or null."""
    if not isinstance(man, dict):
        return f"a JSON {type(man).__name__}, not an object"
    files = man.get("files")
    if not isinstance(files, dict):
        return f"'files' is {files!r}, not an object of file entries" if "files" in man else "no 'files'"
    for name, rec in files.items():
        if not isinstance(rec, dict):
            return f"files[{name!r}] is {rec!r}, not an object"
        if not isinstance(rec.get("bytes"), int) or not isinstance(rec.get("sha256"), str):
            return f"files[{name!r}] lacks an integer 'bytes' and a string 'sha256'"
    cameras = man.get("cameras", [])
    if not isinstance(cameras, list) or not all(isinstance(c, dict) for c in cameras):
        return "'cameras' is not a list of camera objects"
    for key in ("exposure", "depth_scale"):
        value = man.get(key)
        if value is not None and (isinstance(value, bool) or not isinstance(value, int | float)):
            return f"{key!r} is {value!r}, not a number"
    return None


#: Values of ``data.verify_checksums`` (docs/data.md, "The store"): ``once`` (the default) checks each
#: file's SHA-256 against the manifest on its first load in a process (again if its size or mtime changed);
#: ``always`` on every load; ``never`` not at all (true and false, the old spellings, mean always and never).
VERIFY_MODES = ("once", "always", "never")


def verify_mode(value: object) -> str:
    """The :data:`VERIFY_MODES` entry ``data.verify_checksums`` names; ValueError naming the key otherwise."""
    if isinstance(value, bool):
        return "always" if value else "never"
    if value not in VERIFY_MODES:
        raise ValueError(f"data.verify_checksums={value!r}: expected one of {', '.join(VERIFY_MODES)}")
    return str(value)


class StoreReader:
    """Reads one data profile's scenes from the store. See the module docstring."""

    def __init__(
        self,
        data_dir: str | Path,
        data_cfg: DictConfig,
        scenes_dir: str | Path | None = None,
        overrides: Iterable[str] | None = None,
    ):
        """``overrides``: the command-line overrides that made this config (its store-shaping ones are
        repeated in the commands the store's errors print); ``None``: the data settings, spelled out."""
        self.data_cfg = data_cfg
        self.profile = check_name(str(data_cfg.name), "data.name")
        self.data_dir = resolve_data_dir(data_dir)
        self.root = self.data_dir / self.profile
        self.scenes_dir = resolve_scenes_dir(scenes_dir)
        self.specs: dict[str, SceneSpec] = {
            check_name(str(name), "data.scenes key"): SceneSpec.from_cfg(name, scfg, self.scenes_dir)
            for name, scfg in data_cfg.scenes.items()
        }
        for key in ("train_scenes", "transfer_scenes", "test_scenes"):
            for name in data_cfg.get(key) or []:
                if name not in self.specs:
                    raise ValueError(
                        f"data.{key} names scene {name!r}, which is not registered in data.scenes "
                        f"(registered: {sorted(self.specs)}); give the scene file's path in the list instead "
                        f"(data.{key}=[path/to/scene.xml]) or register it with "
                        f"'+data.scenes.{name}={{kind: xml, file: /path/to/scene.xml}}' (docs/scenes.md)"
                    )
        self._manifests: dict[str, dict] = {}
        self._warned: set[str] = set()
        self._replaced: dict[str, int] = {}  # values load replaced by 0, per file loaded in this process
        self.verify_mode = verify_mode(data_cfg.get("verify_checksums", "once"))
        self._verified: set[tuple[str, int, int]] = set()  # (path, bytes, mtime_ns) checked in this process
        shaping = ([o for o in overrides if STORE_OVERRIDE.match(o)] if overrides is not None
                   else self._settings_overrides())
        data_dir = f"paths.data_dir={self.data_dir}"
        self.overrides = [*(o for o in shaping if not o.startswith("paths.data_dir=")), data_dir]

    @classmethod
    def from_cfg(cls, cfg: DictConfig, overrides: Iterable[str] | None = None) -> Self:
        """The store of the full Hydra config (``cfg.data``, ``cfg.paths``; the builder also ``cfg.render``).

        Scenes given by path in ``cfg.data``'s scene lists are registered first, in ``cfg`` itself
        (:func:`mcd.data.scenes.register_paths`), so that the datamodule built from the same ``cfg`` reads
        them.

        ``overrides`` default to those of the running Hydra app (``python -m mcd.run``/``mcd.render``).
        """
        if overrides is None:
            from hydra.core.hydra_config import HydraConfig

            if HydraConfig.initialized():
                overrides = list(HydraConfig.get().overrides.task)
        from mcd.data.scenes import register_paths

        register_paths(cfg)
        return cls._of_cfg(cfg, overrides)

    @classmethod
    def _of_cfg(cls, cfg: DictConfig, overrides: Iterable[str] | None) -> Self:
        return cls(cfg.paths.data_dir, cfg.data, cfg.paths.get("scenes_dir"), overrides)

    # ----------------------------------------------------------------------------------------------- layout
    @property
    def scene_names(self) -> list[str]:
        """The scenes this profile uses (train, transfer and test), in config order, without repeats."""
        names: list[str] = []
        for key in ("train_scenes", "transfer_scenes", "test_scenes"):
            for n in self.data_cfg.get(key) or []:
                if n not in names:
                    names.append(n)
        return names

    @property
    def n_frames(self) -> int:
        return int(self.data_cfg.segments) * int(self.data_cfg.frames_per_segment)

    def path(self, scene: str, frame: int, buffer: str) -> Path:
        return self.root / scene / f"{frame:04d}" / f"{buffer}.exr"

    def manifest_path(self, scene: str) -> Path:
        return self.root / scene / "manifest.json"

    def render_command(self, *extra: str) -> str:
        """The ``python -m mcd.render`` command of this store (with the overrides that shaped it)."""
        return shlex.join(["python", "-m", "mcd.render", *self.overrides, *extra])

    def fix_command(self, buffer: str | None = None) -> str:
        """The command that checks the store (``buffer`` only, when given) and re-renders damaged files."""
        only = [f"render.buffers=[{buffer}]"] if buffer else []
        return f"{self.render_command(*only, 'render.verify=true')} (re-renders damaged files)"

    def _settings_overrides(self) -> list[str]:
        """``data.*`` overrides that reproduce this store's settings and scenes (when no command line is
        known)."""
        settings = store_settings(self.data_cfg)
        values = [f"data.{k}={'null' if v is None else v}" for k, v in settings.items()
                  if k not in SCENE_LISTS]
        scenes = [f"data.{k}=[{','.join(self.data_cfg.get(k) or [])}]" for k in SCENE_LISTS]
        return [*values, *scenes]

    # --------------------------------------------------------------------------------------------- manifest
    def manifest(self, scene: str) -> dict:
        """The scene's manifest (read from disk once), or an error naming the command that renders it."""
        if scene not in self._manifests:
            p = self.manifest_path(scene)
            if not p.is_file():
                raise FileNotFoundError(f"{p}: no manifest; render the data first: {self.render_command()}")
            self._manifests[scene] = self._read_manifest(p)
        return self._manifests[scene]

    def _read_manifest(self, path: Path) -> dict:
        """A manifest from disk; :class:`CorruptManifestError` naming it and the fix if it is not JSON."""
        try:
            man = json.loads(path.read_text())
        except (ValueError, UnicodeDecodeError) as err:
            raise CorruptManifestError(
                f"{path}: truncated or corrupt manifest ({type(err).__name__}: {err}). Fix: "
                f"{self.render_command('render.verify=true')} (renders the scene's files again)"
            ) from err
        problem = manifest_problem(man)
        if problem:
            raise CorruptManifestError(f"{path}: not a store manifest ({problem}). Fix: "
                                       f"{self.render_command('render.verify=true')} (renders the scene's "
                                       "files again)")
        return man

    def cameras(self, scene: str) -> list[Camera]:
        return [Camera.from_dict(c) for c in self.manifest(scene)["cameras"]]

    # --------------------------------------------------------------------------------------------- reading
    def _check_not_replaced(self, scene: str, man: dict, path: Path) -> None:
        """StoreReplacedError where ``scene``'s manifest on disk records other settings than ``man``, the one
        this process read: another command rendered the store again with other ``data.*`` settings under the
        same ``data.name`` while this one used it (a run then failed at its test, after training, on
        "truncated or corrupt EXR" with a render command that would have re-rendered it back)."""
        try:
            now = json.loads(self.manifest_path(scene).read_text())
        except (OSError, ValueError):
            return
        was = man.get("settings") or {}
        new = now.get("settings") if isinstance(now, dict) else None
        if not isinstance(new, dict) or new == was:
            return
        changed = ", ".join(f"{k} {was.get(k)} -> {new.get(k)}" for k in sorted({*was, *new})
                            if was.get(k) != new.get(k))
        raise StoreReplacedError(
            f"{path}: the store {self.root} was rendered again with other settings ({changed}) while this "
            "process read it: another mcd.render or mcd.run used the same data.name with other data.* "
            "settings. Give each setting its own data.name, then run this again (an interrupted run resumes "
            "with ckpt_path=auto)")

    def load(self, scene: str, frame: int, buffer: str, verify: bool | None = None) -> np.ndarray:
        """One stored buffer as float32 ``(H, W, C)``: checked, sanitised, exposure / depth normalised.

        Raises :class:`CorruptEXRError` (naming the fix command) for a truncated, unreadable or
        checksum-mismatched file, FileNotFoundError for a buffer never rendered. The checksum is checked as
        ``data.verify_checksums`` says (:func:`verify_mode`; by default on the first load of each file in this
        process); ``verify`` True or False overrides it for this call.
        """
        man = self.manifest(scene)
        p = self.path(scene, frame, buffer)
        rec = man["files"].get(f"{frame:04d}/{buffer}.exr")
        if rec is None or not p.is_file():
            raise FileNotFoundError(
                f"{p}: buffer {buffer!r} of frame {frame} was not rendered; run "
                f"{self.render_command(f'render.buffers=[{buffer}]')} (or call store.ensure with it)"
            )
        size = p.stat().st_size
        if size != rec["bytes"]:
            self._check_not_replaced(scene, man, p)
            raise CorruptEXRError(p, f"{size} bytes, the manifest says {rec['bytes']}",
                                  self.fix_command(buffer))
        seen = (str(p), size, p.stat().st_mtime_ns)
        if verify is None:
            once = self.verify_mode == "once" and seen not in self._verified
            verify = self.verify_mode == "always" or once
        if verify:
            if sha256(p) != rec["sha256"]:
                self._check_not_replaced(scene, man, p)
                raise CorruptEXRError(p, "checksum differs from the manifest", self.fix_command(buffer))
            self._verified.add(seen)
        img = read_exr(p, self.fix_command(buffer))
        if img.shape[-1] != CHANNELS[buffer]:
            raise CorruptEXRError(
                p, f"{img.shape[-1]} channels, {buffer} has {CHANNELS[buffer]}", self.fix_command(buffer)
            )
        img, n_bad = normalise(img, buffer, man.get("exposure") or 1.0, man.get("depth_scale") or 1.0,
                               colour=buffer in COLOUR_BUFFERS)
        self._replaced[str(p)] = n_bad
        if n_bad and str(p) not in self._warned:
            self._warned.add(str(p))
            log.warning(
                "%s: %d NaN/Inf/negative values (after scaling) replaced by 0 (manifest: nan %d, inf %d, "
                "negative %d)",
                p,
                n_bad,
                rec.get("nan", 0),
                rec.get("inf", 0),
                rec.get("negative", 0),
            )
        return img

    def frame_count(self, scene: str) -> int:
        return len(self.manifest(scene)["cameras"])

    def replaced_counts(self, frames: dict[str, Iterable[int]], buffers: Iterable[str]) -> dict[str, Any]:
        """The NaN/Inf/negative values :meth:`load` replaces by 0 in the files of ``buffers`` of ``frames``
        (``{scene: frame numbers}``), what a run's ``metrics.json`` records (``data.replaced_by_0``):
        ``{"values", "files", "by_buffer": {buffer: values}}``. A file this process loaded counts what its
        load replaced (finite values the exposure scales past float32's range included); one it did not
        (read in a loader worker process, ``data.num_workers`` > 0) counts its manifest record's NaN, Inf
        and negative values, which :meth:`load` replaces alike (docs/data.md)."""
        values, files, by_buffer = 0, 0, {}
        for scene, numbers in frames.items():
            records = self.manifest(scene)["files"]
            for frame in sorted(set(numbers)):
                for buffer in buffers:
                    rec = records.get(f"{frame:04d}/{buffer}.exr")
                    if rec is None:
                        continue
                    n = self._replaced.get(str(self.path(scene, frame, buffer)))
                    if n is None:
                        n = sum(int(rec.get(k) or 0) for k in ("nan", "inf", "negative"))
                    if n:
                        values, files = values + n, files + 1
                        by_buffer[buffer] = by_buffer.get(buffer, 0) + n
        return {"values": values, "files": files, "by_buffer": by_buffer}

