"""The on-disk benchmark store (docs/architecture.md, "The store"; docs/benchmark.md, "Data protocol").

Layout: ``<data_dir>/<profile>/<scene>/manifest.json`` and
``<data_dir>/<profile>/<scene>/<frame:04d>/<buffer>.exr``.

The manifest records the render settings, the Mitsuba version, the scene's source (file + checksum, or
generator seed), the per-frame cameras, the exposure scale, and per file: spp, seed, variant, byte size,
SHA-256 and the counts of NaN / Inf / negative values the renderer produced. A file is *done* when its
manifest entry exists, its key (everything that determines its content: camera, spp, seed, scene, size, depth
limit) matches the current config, and its size on disk matches; otherwise it is (re-)rendered. Files and the
manifest are written atomically (temp file + rename) and the manifest after every frame, so an interrupted
render resumes where it stopped. ``render.force=true`` re-renders the requested buffers;
``render.verify=true`` also checks every checksum and re-renders damaged files.

Only what is asked for is rendered: :meth:`Store.ensure` takes the buffers a model reads
(docs/architecture.md) plus ``ref``; ``motion`` also needs ``depth``. At load, NaN/Inf (and negative values
where they are not meaningful) are replaced by 0 with one log line per file; colour is multiplied by the
scene's exposure scale (``exposure: auto`` sets the mean of frame 0's reference to ``data.exposure_target``;
recorded in the manifest), depth is divided by the scene's ``depth_scale`` (median first-hit distance of frame
0).
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import logging
import os
import re
import shlex
import tempfile
import time
from collections import Counter
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from omegaconf import DictConfig, OmegaConf

from mcd.data.camera import Camera, backward_motion, interpolate_path
from mcd.data.exposure import NEGATIVE_OK, auto_exposure, depth_scale, normalise
from mcd.data.exr import CorruptEXRError, count_bad, read_exr, sha256, umask_mode, write_exr
from mcd.data.renderer import derive_seed
from mcd.data.scenes import SceneSpec

log = logging.getLogger(__name__)

SPP_BUFFERS = {"c1": 1, "c2": 2, "c4": 4, "c8": 8, "c16": 16, "c32": 32}
COLOUR_BUFFERS = ("c1_in", *SPP_BUFFERS, "ref")
GBUFFERS = ("depth", "normal", "albedo")
BUFFERS = (*COLOUR_BUFFERS, *GBUFFERS, "motion")
CHANNELS = {**dict.fromkeys(COLOUR_BUFFERS, 3), "depth": 1, "normal": 3, "albedo": 3, "motion": 2}
MANIFEST_VERSION = 1
#: A profile or scene name is one folder name of the store: letters, digits, ``_``, ``-``, ``.`` (not leading).
SAFE_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*")


def _hash(obj: Any) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()[:16]


def _write_json_atomic(path: Path, obj: Any) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(obj, f, indent=1)
        os.chmod(tmp, umask_mode())
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def buffer_spp(buffer: str, data_cfg: DictConfig) -> int:
    """Samples per pixel of a stored colour buffer (``c1_in`` 1, ``c<k>`` k, ``ref`` ``data.ref_spp``)."""
    if buffer == "c1_in":
        return 1
    if buffer == "ref":
        return int(data_cfg.ref_spp)
    return SPP_BUFFERS[buffer]


#: Command-line overrides that shape the store (``data=..``, ``data.*``, ``+scene@data.scenes.*``, ``paths.*``).
STORE_OVERRIDE = re.compile(r"[+~]*(data[.=]|scene@data\.|paths\.)")


class CorruptManifestError(RuntimeError):
    """A scene's ``manifest.json`` is not readable JSON; the message names it and the command that fixes it."""


def check_name(name: str, key: str) -> str:
    """``name`` if it is a single safe folder name (:data:`SAFE_NAME`), else ValueError naming ``key``.

    Profile and scene names become folders of the store; ``..`` or ``/`` would write outside
    ``paths.data_dir``.
    """
    if not SAFE_NAME.fullmatch(name):
        raise ValueError(
            f"{key}={name!r}: not a plain folder name (letters, digits, '_', '-', '.', not leading '.'); the "
            "store writes <paths.data_dir>/<data.name>/<scene>/, so a name must not hold '/' or '..'"
        )
    return name


def validate_buffers(buffers: Iterable[str]) -> set[str]:
    bad = sorted(set(buffers) - set(BUFFERS))
    if bad:
        raise ValueError(f"unknown buffer(s) {bad}; the store holds {list(BUFFERS)} (docs/architecture.md)")
    return set(buffers)


class Store:
    """Renders (on demand) and reads one data profile's scenes. See the module docstring."""

    def __init__(
        self,
        data_dir: str | Path,
        data_cfg: DictConfig,
        render_cfg: DictConfig | None = None,
        scenes_dir: str | Path | None = None,
        overrides: Iterable[str] | None = None,
    ):
        """``overrides``: the command-line overrides that made this config (its store-shaping ones are
        repeated in the commands the store's errors print); ``None``: the data settings, spelled out."""
        self.data_cfg = data_cfg
        self.render_cfg = render_cfg if render_cfg is not None else OmegaConf.create({})
        self.profile = check_name(str(data_cfg.name), "data.name")
        self.data_dir = Path(data_dir)
        self.root = self.data_dir / self.profile
        self.scenes_dir = scenes_dir
        self.specs: dict[str, SceneSpec] = {
            check_name(str(name), "data.scenes key"): SceneSpec.from_cfg(name, scfg, scenes_dir)
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
        shaping = ([o for o in overrides if STORE_OVERRIDE.match(o)] if overrides is not None
                   else self._settings_overrides())
        data_dir = f"paths.data_dir={self.data_dir}"
        self.overrides = [*(o for o in shaping if not o.startswith("paths.data_dir=")), data_dir]

    @classmethod
    def from_cfg(cls, cfg: DictConfig, overrides: Iterable[str] | None = None) -> Store:
        """The store of the full Hydra config (``cfg.data``, ``cfg.paths``, ``cfg.render``).

        Scenes given by path in ``cfg.data``'s scene lists are registered first, in ``cfg`` itself
        (:func:`mcd.data.scenes.register_paths`), so that the datamodule built from the same ``cfg`` reads them.

        ``overrides`` default to those of the running Hydra app (``python -m mcd.run``/``mcd.render``).
        """
        if overrides is None:
            from hydra.core.hydra_config import HydraConfig

            if HydraConfig.initialized():
                overrides = list(HydraConfig.get().overrides.task)
        from mcd.data.scenes import register_paths

        register_paths(cfg)
        return cls(cfg.paths.data_dir, cfg.data, cfg.get("render"), cfg.paths.get("scenes_dir"), overrides)

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
        """``data.*`` overrides that reproduce this store's settings and scenes (when no command line is known)."""
        d = self.data_cfg
        keys = ("width", "height", "segments", "frames_per_segment", "ref_spp", "gbuffer_spp", "max_depth", "seed")
        scenes = [f"data.{k}=[{','.join(d.get(k) or [])}]" for k in ("train_scenes", "transfer_scenes", "test_scenes")]
        return [f"data.name={self.profile}", *(f"data.{k}={'null' if d[k] is None else d[k]}" for k in keys if k in d), *scenes]

    # --------------------------------------------------------------------------------------------- manifest
    def _settings(self) -> dict[str, Any]:
        d = self.data_cfg
        return {
            "width": int(d.width),
            "height": int(d.height),
            "segments": int(d.segments),
            "frames_per_segment": int(d.frames_per_segment),
            "frames": self.n_frames,
            "max_depth": None if d.get("max_depth") is None else int(d.max_depth),
            "ref_spp": int(d.ref_spp),
            "gbuffer_spp": int(d.gbuffer_spp),
            "rfilter": "box",
            "seed": int(d.get("seed", 0)),
            "max_samples_per_pass": int(self.render_cfg.get("max_samples_per_pass", 1 << 24)),
        }

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
        if not isinstance(man, dict) or "files" not in man:
            raise CorruptManifestError(f"{path}: not a store manifest (no 'files'). Fix: "
                                       f"{self.render_command('render.verify=true')}")
        return man

    def cameras(self, scene: str) -> list[Camera]:
        return [Camera.from_dict(c) for c in self.manifest(scene)["cameras"]]

    def _camera_key(self, spec: SceneSpec, source: dict) -> str:
        s = self._settings()
        return _hash(
            [source["sha256"], spec.path, s["width"], s["height"], s["segments"], s["frames_per_segment"]]
        )

    def _file_key(self, man: dict, frame: int, buffer: str) -> str:
        s = self._settings()
        base = [
            man["source"]["sha256"],
            man["cameras"][frame],
            s["width"],
            s["height"],
            s["max_depth"],
            s["seed"],
        ]
        if buffer in COLOUR_BUFFERS:
            return _hash([*base, buffer, buffer_spp(buffer, self.data_cfg)])
        if buffer in GBUFFERS:
            return _hash([*base, buffer, s["gbuffer_spp"]])
        prev = man["cameras"][max(frame - 1, 0)]
        return _hash([*base, "motion", prev, self._file_key(man, frame, "depth")])

    def _is_done(self, man: dict, scene: str, frame: int, buffer: str, verify: bool) -> bool:
        rel = f"{frame:04d}/{buffer}.exr"
        rec = man["files"].get(rel)
        p = self.path(scene, frame, buffer)
        if rec is None or rec.get("key") != self._file_key(man, frame, buffer) or not p.is_file():
            return False
        if p.stat().st_size != rec["bytes"]:
            log.warning(
                "%s: size %d differs from the manifest's %d (truncated?): re-rendering",
                p,
                p.stat().st_size,
                rec["bytes"],
            )
            return False
        if verify and sha256(p) != rec["sha256"]:
            log.warning("%s: checksum differs from the manifest (corrupt): re-rendering", p)
            return False
        return True

    # ------------------------------------------------------------------------------------------- rendering
    def _open_manifest(self, spec: SceneSpec, loader: Any) -> dict:
        """Existing manifest if its cameras still fit the config, else a new one (cameras from `loader()`)."""
        source = spec.source()
        cam_key = self._camera_key(spec, source)
        p = self.manifest_path(spec.name)
        man = None
        if p.is_file():
            try:
                man = self._read_manifest(p)
            except CorruptManifestError:
                if not (self.render_cfg.get("force", False) or self.render_cfg.get("verify", False)):
                    raise
                log.warning("%s: unreadable manifest replaced; every file of the scene is rendered again", p)
        if man is not None and man.get("camera_key") == cam_key and man.get("version") == MANIFEST_VERSION:
            man["source"] = source
            man["settings"] = self._settings()
            return man
        loaded = loader()
        s = self._settings()
        mats = interpolate_path(loaded.nodes, s["frames_per_segment"])
        cams = [Camera(m, loaded.fov, s["width"], s["height"]).to_dict() for m in mats]
        import mitsuba as mi

        new = {
            "version": MANIFEST_VERSION,
            "scene": spec.name,
            "profile": self.profile,
            "source": source,
            "settings": s,
            "camera_key": cam_key,
            "cameras": cams,
            "mitsuba": mi.__version__,
            "exposure": None,
            "depth_scale": None,
            "files": {},
        }
        if (
            man is not None
        ):  # keep the old file entries: their keys decide which files are still valid
            new["files"] = man.get("files", {})
            new["exposure"] = man.get("exposure")
            new["depth_scale"] = man.get("depth_scale")
        return new

    def ensure(
        self, buffers: Iterable[str], scenes: Iterable[str] | None = None, progress: bool = True
    ) -> dict:
        """Render whatever of `buffers` (+ ``ref``) is missing or stale for the profile's scenes.

        Returns ``{"rendered": {buffer: n}, "reused": {buffer: n}, "variant", "seconds", "msamples"}``
        and logs one line saying what was rendered and what was reused.
        """
        want = validate_buffers(buffers) | {"ref"}
        todo_buffers = want | ({"depth"} if "motion" in want else set())
        scene_list = list(scenes) if scenes is not None else self.scene_names
        force = bool(self.render_cfg.get("force", False))
        verify = bool(self.render_cfg.get("verify", False))
        rendered: Counter[str] = Counter()
        reused: Counter[str] = Counter()
        t0 = time.perf_counter()
        msamples = 0.0
        variant = None
        for name in scene_list:  # every scene file before the first render, not after the earlier scenes
            if name not in self.specs:
                raise ValueError(f"scene {name!r} is not registered in data.scenes of profile {self.profile}")
            self.specs[name].check_exists()
        for name in scene_list:
            with self._scene_lock(name):  # one writer per scene; the manifest is read again under the lock
                spec = self.specs[name]
                state: dict[str, Any] = {}

                def loader(spec: SceneSpec = spec, state: dict[str, Any] = state) -> Any:
                    if "loaded" not in state:
                        nonlocal variant
                        variant = variant or self._variant()
                        state["loaded"] = spec.load(
                            int(self.data_cfg.width),
                            int(self.data_cfg.height),
                            self._settings()["max_depth"],
                            int(self.data_cfg.segments),
                        )
                    return state["loaded"]

                man = self._open_manifest(spec, loader)
                order = sorted(todo_buffers, key=BUFFERS.index)
                # ref first so that auto exposure is known early; motion after depth
                order = ["ref", *[b for b in order if b != "ref"]]
                todo = {
                    f: [b for b in order if force or not self._is_done(man, name, f, b, verify)]
                    for f in range(self.n_frames)
                }
                for f in range(self.n_frames):
                    for b in order:
                        if b not in todo[f] and (b in want):
                            reused[b] += 1
                if any(todo.values()):
                    variant = variant or self._variant()
                    msamples += self._render_scene(spec, man, todo, loader(), progress, rendered) / 1e6
                self._fill_scales(spec, man)
                self._manifests[name] = man
                self._save(name, man)
        seconds = time.perf_counter() - t0
        summary = {
            "rendered": dict(rendered),
            "reused": dict(reused),
            "variant": variant,
            "seconds": round(seconds, 3),
            "msamples": round(msamples, 3),
            "scenes": scene_list,
        }
        log.info(
            "store %s (%s): scenes %s; rendered %s; reused %s; %.1f Msamples in %.1f s (variant %s)",
            self.profile,
            self.root,
            ",".join(scene_list),
            _fmt(rendered),
            _fmt(reused),
            msamples,
            seconds,
            variant or "none needed",
        )
        return summary

    @contextlib.contextmanager
    def _scene_lock(self, scene: str) -> Iterator[None]:
        """Hold ``<scene>/.lock`` (``fcntl.flock``) while this process renders the scene.

        A second render of the same scene (another process) waits here, then reads the manifest the first one
        left, so neither loses the other's entries. Under the lock no other process is writing the scene, so
        temp files left by a killed run (``.*.tmp*`` beside the manifest and in frame folders) are removed.
        """
        folder = self.root / scene
        folder.mkdir(parents=True, exist_ok=True)
        with open(folder / ".lock", "a") as f:
            try:
                fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                log.info("%s: another process is rendering this scene; waiting for it to finish", folder)
                fcntl.flock(f, fcntl.LOCK_EX)
            try:
                for stale in [*folder.glob(".*.tmp*"), *folder.glob("*/.*.tmp*")]:  # of a killed run
                    stale.unlink(missing_ok=True)
                yield
            finally:
                fcntl.flock(f, fcntl.LOCK_UN)

    def _variant(self) -> str:
        from mcd.data.mitsuba_env import select_variant

        return select_variant(str(self.render_cfg.get("variant", "auto")))

    def _render_scene(
        self,
        spec: SceneSpec,
        man: dict,
        todo: dict[int, list[str]],
        loaded: Any,
        progress: bool,
        rendered: Counter[str],
    ) -> float:
        import mitsuba as mi
        from tqdm import tqdm

        from mcd.data.renderer import SceneRenderer

        s = self._settings()
        r = SceneRenderer(loaded.scene, s["width"], s["height"], loaded.fov, s["max_samples_per_pass"])
        man["variant"] = mi.variant()
        frames = [f for f in range(self.n_frames) if todo[f]]
        t0 = time.perf_counter()
        bar = tqdm(frames, desc=f"{self.profile}/{spec.name}", unit="frame", disable=not progress, leave=True)
        for f in bar:
            cam = man["cameras"][f]
            r.set_camera(np.asarray(cam["to_world"], dtype=np.float64))
            gb: dict[str, np.ndarray] | None = None
            for b in todo[f]:
                seed = derive_seed(s["seed"], spec.name, f, b)
                if b in COLOUR_BUFFERS:
                    spp = buffer_spp(b, self.data_cfg)
                    img = r.color(spp, seed)
                elif b in GBUFFERS:
                    spp = s["gbuffer_spp"]
                    if gb is None:
                        gb = r.gbuffer(spp, derive_seed(s["seed"], spec.name, f, "gbuffer"))
                    img = gb[b]
                else:
                    spp, seed = 0, 0
                    depth = read_exr(self.path(spec.name, f, "depth"), self.fix_command("depth"))
                    cams = man["cameras"]
                    img = (
                        np.zeros((s["height"], s["width"], 2), np.float32)
                        if f == 0
                        else backward_motion(depth, Camera.from_dict(cams[f]), Camera.from_dict(cams[f - 1]))
                    )
                self._write(spec.name, man, f, b, img, spp, seed, mi.variant())
                rendered[b] += 1
                if f == 0 and b == "ref":
                    self._set_exposure(spec, man, img)
                if f == 0 and b == "depth":
                    man["depth_scale"] = depth_scale(img)
            self._save(spec.name, man)
            dt = time.perf_counter() - t0
            bar.set_postfix_str(f"{r.samples_rendered / 1e6 / max(dt, 1e-9):.2f} Msamples/s")
        bar.close()
        self._manifests[spec.name] = man
        return float(r.samples_rendered)

    def _fill_scales(self, spec: SceneSpec, man: dict) -> None:
        """Exposure and depth scale from frame 0 when unknown (e.g. files kept from an older manifest)."""
        if spec.exposure != "auto":
            man["exposure"] = float(spec.exposure)
        elif man.get("exposure") is None and "0000/ref.exr" in man["files"]:
            self._set_exposure(spec, man, read_exr(self.path(spec.name, 0, "ref"), self.fix_command("ref")))
        if man.get("depth_scale") is None and "0000/depth.exr" in man["files"]:
            man["depth_scale"] = depth_scale(read_exr(self.path(spec.name, 0, "depth"), self.fix_command("depth")))

    def _set_exposure(self, spec: SceneSpec, man: dict, ref0: np.ndarray) -> None:
        if spec.exposure != "auto":
            man["exposure"] = float(spec.exposure)
            return
        exposure = auto_exposure(ref0, float(self.data_cfg.get("exposure_target", 0.5)))
        man["exposure"] = exposure or 1.0
        if exposure is None:
            log.warning("scene %s: frame 0's reference is black; exposure left at 1", spec.name)

    def _write(
        self,
        scene: str,
        man: dict,
        frame: int,
        buffer: str,
        img: np.ndarray,
        spp: int,
        seed: int,
        variant: str,
    ) -> None:
        p = self.path(scene, frame, buffer)
        write_exr(p, img, compress=buffer not in COLOUR_BUFFERS)
        man["files"][f"{frame:04d}/{buffer}.exr"] = {
            "key": self._file_key(man, frame, buffer),
            "spp": spp,
            "seed": seed,
            "variant": variant,
            "bytes": p.stat().st_size,
            "sha256": sha256(p),
            **count_bad(img, buffer in NEGATIVE_OK),
        }

    def _save(self, scene: str, man: dict) -> None:
        _write_json_atomic(self.manifest_path(scene), man)

    # --------------------------------------------------------------------------------------------- reading
    def load(self, scene: str, frame: int, buffer: str, verify: bool | None = None) -> np.ndarray:
        """One stored buffer as float32 ``(H, W, C)``: checked, sanitised, exposure / depth normalised.

        Raises :class:`CorruptEXRError` (naming the fix command) for a truncated, unreadable or (with
        ``data.verify_checksums``) checksum-mismatched file, FileNotFoundError for a buffer never rendered.
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
            raise CorruptEXRError(p, f"{size} bytes, the manifest says {rec['bytes']}", self.fix_command(buffer))
        verify = bool(self.data_cfg.get("verify_checksums", False)) if verify is None else verify
        if verify and sha256(p) != rec["sha256"]:
            raise CorruptEXRError(p, "checksum differs from the manifest", self.fix_command(buffer))
        img = read_exr(p, self.fix_command(buffer))
        if img.shape[-1] != CHANNELS[buffer]:
            raise CorruptEXRError(
                p, f"{img.shape[-1]} channels, {buffer} has {CHANNELS[buffer]}", self.fix_command(buffer)
            )
        img, n_bad = normalise(img, buffer, man.get("exposure") or 1.0, man.get("depth_scale") or 1.0,
                               colour=buffer in COLOUR_BUFFERS)
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


def _fmt(c: Counter[str]) -> str:
    if not c:
        return "nothing"
    return ", ".join(f"{b} x{c[b]}" for b in BUFFERS if c.get(b))
