"""Rendering the on-disk benchmark store (docs/architecture.md, "The store"; docs/benchmark.md, "Data
protocol"; docs/data.md, "Buffers, seeds, store").

:class:`StoreBuilder` is a :class:`mcd.data.store.StoreReader` that also renders: :meth:`StoreBuilder.ensure`
renders whatever of the asked buffers (those a model reads, plus ``ref``; ``motion`` also needs ``depth``) is
missing or stale. The manifest records the render settings, the Mitsuba version, the scene's source (file +
checksum, or generator seed), the per-frame cameras, the exposure scale, and per file: spp, seed, variant,
byte size, SHA-256 and the counts of NaN / Inf / negative values the renderer produced. A file is *done* when
its manifest entry exists, its key (everything that determines its content: camera, spp, seed, scene, size,
depth limit) matches the current config, and its size on disk matches; otherwise it is (re-)rendered. Files
and the manifest are written atomically (:mod:`mcd.core.atomic_write`), the manifest after every frame, so
an interrupted render resumes where it stopped. Several processes may render one store at once (the shards of
``render.shard``, :mod:`mcd.data.shards`, or identical renders): a frame is rendered under its own lock
(``<scene>/<frame>/.lock``), and the manifest is read, merged and written under a short scene lock
(``<scene>/.lock``), so no unit is rendered twice and no entry is lost (:meth:`StoreBuilder._ensure_scene`).
``render.force=true`` re-renders the requested buffers; ``render.verify=true`` also checks every checksum and
re-renders damaged files.

Reference quality (docs/data.md, "Reference quality"): with ``data.ref_quality.target_db`` set, a pilot of
each scene (frame 0 as two independent halves of ``data.ref_spp``) estimates its reference PSNR
(:mod:`mcd.data.reference_quality`), and the references of the scene's test frames are rendered at the spp
that reaches the target (at most ``data.ref_quality.max_spp``), as two halves whose difference gives each
one's achieved PSNR (``psnr_estimate`` in the manifest). Training and validation frames keep ``data.ref_spp``.
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import json
import logging
import time
from collections import Counter
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Self

import numpy as np
from omegaconf import DictConfig, OmegaConf

from mcd.core import file_lock
from mcd.core.atomic_write import atomic_write_json
from mcd.data.buffers import BUFFERS, COLOUR_BUFFERS, GBUFFERS, NEGATIVE_OK, buffer_spp, validate_buffers
from mcd.data.camera import Camera, backward_motion, interpolate_path
from mcd.data.exposure import auto_exposure, depth_scale
from mcd.data.exr import count_bad, read_exr, sha256, write_exr
from mcd.data.reference_quality import estimate_psnr, spp_for_target
from mcd.data.renderer import derive_seed
from mcd.data.scenes import SceneSpec
from mcd.data.shards import Selection
from mcd.data.splits import test_frame_count
from mcd.data.store import CorruptManifestError, StoreReader

#: the reader's logger: every log line of the store, read or render, comes from ``mcd.data.store``
log = logging.getLogger("mcd.data.store")

MANIFEST_VERSION = 1


def reads_changed(man: dict, source: dict) -> bool:
    """Whether a manifest's scene ``source`` records other files read (``reads``,
    :func:`mcd.data.scenes.reads_digest`) than the scene reads now; a manifest from before the key: no."""
    recorded = (man.get("source") or {}).get("reads")
    return recorded is not None and recorded != source.get("reads")


def upgraded(on_disk: dict, man: dict) -> dict:
    """``on_disk`` with what this code adds to a manifest from before it and ``man`` holds (``reads`` in the
    scene's source, ``exposure_target``): a scene whose manifest differs from it only so is reused by reading
    alone, without a write (a store on a read-only mount still trains)."""
    out = dict(on_disk)
    source = out.get("source")
    if isinstance(source, dict) and "reads" not in source and "reads" in man.get("source", {}):
        out["source"] = {**out["source"], "reads": man["source"]["reads"]}
    if "exposure_target" not in out and "exposure_target" in man:
        out["exposure_target"] = man["exposure_target"]
    return out


def _hash(obj: Any) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()[:16]


class StoreBuilder(StoreReader):
    """Renders (on demand) and reads one data profile's scenes. See the module docstring."""

    def __init__(
        self,
        data_dir: str | Path,
        data_cfg: DictConfig,
        render_cfg: DictConfig | None = None,
        scenes_dir: str | Path | None = None,
        overrides: Iterable[str] | None = None,
    ):
        """As :class:`mcd.data.store.StoreReader`, with the ``render.*`` settings (variant, force, verify,
        ``max_samples_per_pass``)."""
        super().__init__(data_dir, data_cfg, scenes_dir, overrides)
        self.render_cfg = render_cfg if render_cfg is not None else OmegaConf.create({})

    @classmethod
    def _of_cfg(cls, cfg: DictConfig, overrides: Iterable[str] | None) -> Self:
        return cls(cfg.paths.data_dir, cfg.data, cfg.get("render"), cfg.paths.get("scenes_dir"), overrides)

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

    # ------------------------------------------------------------------------------------ reference quality
    def _quality_cfg(self) -> dict[str, Any] | None:
        """``data.ref_quality`` as ``{"target_db", "max_spp"}``, or None where it is off (no target)."""
        q = self.data_cfg.get("ref_quality")
        if q is None or q.get("target_db") is None:
            return None
        target, cap = float(q.target_db), int(q.get("max_spp", self.data_cfg.ref_spp))
        if cap < int(self.data_cfg.ref_spp):
            raise ValueError(f"data.ref_quality.max_spp={cap} is below data.ref_spp={self.data_cfg.ref_spp}: "
                             "raise it (or set data.ref_quality.target_db=null)")
        return {"target_db": target, "max_spp": cap}

    def _quality_frame(self, man: dict, frame: int) -> bool:
        """Whether ``frame``'s reference is rendered to the scene's reference quality (a test frame, with
        ``data.ref_quality`` on and the scene's pilot done)."""
        return man.get("ref_quality") is not None and frame < test_frame_count(
            self.n_frames, float(self.data_cfg.get("test_fraction", 0.2)))

    def _ref_spp(self, man: dict, frame: int) -> int:
        """The reference spp of ``frame``: the scene's quality spp for a test frame, else ``data.ref_spp``."""
        if self._quality_frame(man, frame):
            return int(man["ref_quality"]["spp"])
        return int(self.data_cfg.ref_spp)

    def _pilot(self, spec: SceneSpec, man: dict, loaded: Any, quality: dict[str, Any]) -> dict[str, Any]:
        """Estimate the scene's reference PSNR from frame 0 rendered as two halves of ``data.ref_spp`` and
        choose the spp that reaches ``quality["target_db"]`` (docs/data.md, "Reference quality")."""
        from mcd.data.renderer import SceneRenderer

        s = self._settings()
        pilot = int(self.data_cfg.ref_spp)
        r = SceneRenderer(loaded.scene, s["width"], s["height"], loaded.fov, s["max_samples_per_pass"])
        r.set_camera(np.asarray(man["cameras"][0]["to_world"], dtype=np.float64))
        halves = [r.color(pilot // 2, derive_seed(s["seed"], spec.name, 0, "ref_pilot", k)) for k in (0, 1)]
        target = float(self.data_cfg.get("exposure_target", 0.5))
        exposure = (float(spec.exposure) if spec.exposure != "auto"
                    else auto_exposure((halves[0] + halves[1]) / 2, target,
                                       f"scene {spec.name}: frame 0's pilot reference") or 1.0)
        db = estimate_psnr(halves[0], halves[1], exposure)
        spp = spp_for_target(pilot, db, quality["target_db"], quality["max_spp"])
        log.info("scene %s: reference of frame 0 at %d spp estimated at %.1f dB; test-frame references at %d "
                 "spp for a target of %.0f dB%s", spec.name, pilot, db, spp, quality["target_db"],
                 " (capped by data.ref_quality.max_spp)" if spp == quality["max_spp"] else "")
        return {**quality, "pilot_spp": pilot, "pilot_db": round(db, 3), "spp": spp,
                "samples": r.samples_rendered}

    def _pilot_exposure(self, spec: SceneSpec) -> dict[str, float]:
        """The exposure the pilot's PSNR is estimated at (:meth:`_pilot`): the scene's fixed ``exposure``, or
        the auto exposure's ``data.exposure_target``. Display-mapped errors depend on it, so the test frames'
        spp does too."""
        if spec.exposure != "auto":
            return {"fixed": float(spec.exposure)}
        return {"target": float(self.data_cfg.get("exposure_target", 0.5))}

    def _pilot_stale(self, spec: SceneSpec, man: dict, quality: dict[str, Any]) -> bool:
        """Whether the scene's reference-quality pilot must run (again): none recorded, or one of other
        settings (:meth:`_pilot_key`) or of another exposure (:meth:`_pilot_exposure`; a pilot recorded
        without it was estimated at the default target, 0.5, or at the scene's fixed exposure of then, so a
        store of the default target keeps it and another runs it again: a render of frame 0)."""
        rq = man.get("ref_quality") or {}
        return (rq.get("key") != self._pilot_key(man, quality)
                or rq.get("exposure", {"target": 0.5}) != self._pilot_exposure(spec))

    def _pilot_key(self, man: dict, quality: dict[str, Any]) -> str:
        s = self._settings()
        return _hash([man["source"]["sha256"], man["cameras"][0], s["width"], s["height"], s["max_depth"],
                      s["seed"], s["ref_spp"], quality])

    def reference_quality(self, scene: str) -> dict[str, Any]:
        """What the scene's references reached (docs/data.md, "Reference quality"): the test frames' spp and
        the mean and lowest ``psnr_estimate`` of their references (None without ``data.ref_quality``), the
        target, and the training frames' spp."""
        man = self.manifest(scene)
        rq = man.get("ref_quality")
        n_test = test_frame_count(self.n_frames, float(self.data_cfg.get("test_fraction", 0.2)))
        est = [man["files"].get(f"{f:04d}/ref.exr", {}).get("psnr_estimate") for f in range(n_test)]
        est = [e for e in est if e is not None]
        return {"test_spp": None if rq is None else rq["spp"],
                "target_db": None if rq is None else rq["target_db"],
                "test_psnr_db": round(float(np.mean(est)), 2) if est else None,
                "test_psnr_min_db": round(float(np.min(est)), 2) if est else None,
                "pilot_db": None if rq is None else rq["pilot_db"], "train_spp": int(self.data_cfg.ref_spp)}

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
        if buffer == "ref" and self._quality_frame(man, frame):
            return _hash([*base, buffer, self._ref_spp(man, frame), "halves"])
        if buffer in COLOUR_BUFFERS:
            return _hash([*base, buffer, buffer_spp(buffer, self.data_cfg)])
        if buffer in GBUFFERS:
            return _hash([*base, buffer, s["gbuffer_spp"]])
        prev = man["cameras"][max(frame - 1, 0)]
        return _hash([*base, "motion", prev, self._file_key(man, frame, "depth")])

    def check_rendered(self, frames: dict[str, list[int]], buffers: Iterable[str]) -> None:
        """ValueError unless every file of ``buffers`` of ``frames`` (``{scene: frame numbers}``) is what this
        config renders: listed in the scene's manifest with this config's render key, from cameras of this
        config. Reads the manifests and the scene files, renders nothing. A reader of the store that does not
        render (``python -m mcd.pack``) calls it before any work: it packed a store rendered with other
        ``data.*`` settings under the same ``data.name`` as if it were this config's (a 32x32 store packed
        for ``data.ref_spp=64`` said "packed 10"; for ``data.width=48`` it failed on a broadcast)."""
        buffers = list(buffers)
        for scene, numbers in frames.items():
            man = self.manifest(scene)
            spec = self.specs[scene]
            source = spec.source()
            same_cameras = (man.get("camera_key") == self._camera_key(spec, source)
                            and max(numbers, default=-1) < len(man["cameras"])
                            and not reads_changed(man, source))
            stale = [f"{f:04d}/{b}.exr" for f in numbers for b in buffers
                     if not same_cameras or man["files"].get(f"{f:04d}/{b}.exr", {}).get("key")
                     != self._file_key(man, f, b)]
            if not stale:
                continue
            was, now = man.get("settings") or {}, self._settings()
            changed = ", ".join(f"{k} {was.get(k)} there, {now.get(k)} here" for k in sorted({*was, *now})
                                if was.get(k) != now.get(k)) or "other render settings or scene file"
            raise ValueError(
                f"{self.manifest_path(scene)}: {len(stale)} file(s) this command reads (e.g. {stale[0]}) "
                f"were rendered with other settings than this command's ({changed}); render them first: "
                f"{self.render_command('render.buffers=[' + ','.join(buffers) + ']')} (or give each setting "
                "its own data.name)")

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
        if man is not None and reads_changed(man, source):
            log.warning("scene %s: a file it reads (a mesh, a texture, an included XML) changed since it was "
                        "rendered: every file of the scene is rendered again", spec.name)
            man = None  # a new manifest, no file kept: each was rendered from the old scene
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
        self,
        buffers: Iterable[str],
        scenes: Iterable[str] | None = None,
        progress: bool = True,
        selection: Selection | None = None,
    ) -> dict:
        """Render whatever of `buffers` (+ ``ref``) is missing or stale for the profile's scenes, or for the
        share of their (scene, frame) units that `selection` picks (``render.shard``, ``render.scenes``,
        ``render.frames``: :mod:`mcd.data.shards`).

        Several processes may run this on one store at once (the shards of a profile, or identical renders):
        see :meth:`_ensure_scene`. With `progress`, one log line per scene and per rendered frame (elapsed,
        ETA; plain lines, fit for a log file).

        Returns ``{"rendered": {buffer: n}, "reused": {buffer: n}, "variant", "seconds", "msamples",
        "scenes", "reference", "selection"}`` and logs one line saying what was rendered and what was reused.
        """
        want = validate_buffers(buffers) | {"ref"}
        todo_buffers = want | ({"depth"} if "motion" in want else set())
        order = sorted(todo_buffers, key=BUFFERS.index)
        order = ["ref", *[b for b in order if b != "ref"]]  # ref first (exposure); motion after depth
        scene_list = list(scenes) if scenes is not None else self.scene_names
        sel = selection or Selection()
        for name in scene_list:  # every scene file before the first render, not after the earlier scenes
            if name not in self.specs:
                raise ValueError(f"scene {name!r} is not registered in data.scenes of profile {self.profile}")
            self.specs[name].check_readable()
        try:  # the store's folder, before the first lock: paths.data_dir named where it cannot be made
            self.root.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise ValueError(f"paths.data_dir={self.data_dir} (or MCD_DATA_DIR): cannot make the store's "
                             f"folder {self.root} ({err.strerror or err}); give a writable folder") from None
        units = sel.units(scene_list, self.n_frames)
        tally = _Tally()
        t0 = time.perf_counter()
        for k, (name, frames) in enumerate(units.items()):
            position = f"{k + 1}/{len(units)}" if progress else None
            self._ensure_scene(name, frames, want, order, tally, position)
            self._manifests[name] = self._read_manifest(self.manifest_path(name))  # every process's entries
        seconds = time.perf_counter() - t0
        summary = {
            "rendered": dict(tally.rendered),
            "reused": dict(tally.reused),
            "variant": tally.variant,
            "seconds": round(seconds, 3),
            "msamples": round(tally.msamples, 3),
            "scenes": list(units),
            "reference": {name: self.reference_quality(name) for name in units},
            "selection": sel.describe(),
        }
        log.info(
            "store %s (%s): scenes %s (%s); rendered %s; reused %s; %.1f Msamples in %.1f s (variant %s)",
            self.profile,
            self.root,
            ",".join(units),
            sel.describe(),
            _fmt(tally.rendered),
            _fmt(tally.reused),
            tally.msamples,
            seconds,
            tally.variant or "none needed",
        )
        return summary

    def _ensure_scene(
        self, name: str, frames: list[int], want: set[str], order: list[str], tally: _Tally,
        position: str | None,
    ) -> None:
        """Render what `frames` of scene `name` lack of `order`, safely beside other writers of the scene.

        1. Under the scene lock (``<scene>/.lock``, short): the manifest is opened or made (cameras), the
           scene's reference-quality pilot is run if its key changed, known scales are filled, stale temp
           files of dead writers are removed, and the manifest is saved: the first process to need the scene's
           facts computes them, the others read them.
        2. Auto exposure (frame 0's reference) is needed before any other test frame's reference half-split
           estimate; if unknown, frame 0's reference is rendered first, under frame 0's lock, by whichever
           process needs it first.
        3. Each frame is rendered outside the scene lock, under its own lock (``<scene>/<frame>/.lock``),
           after reading the manifest again: what another process rendered since is not rendered twice. Busy
           frames are skipped and taken last. After each frame, this process's new entries (and frame 0's
           scales) are merged into the manifest read again under the scene lock: no process loses another's
           entries.
        """
        spec = self.specs[name]
        force = bool(self.render_cfg.get("force", False))
        verify = bool(self.render_cfg.get("verify", False))
        state: dict[str, Any] = {}
        self._check_scene_lock(name)
        self._check_frame_folders(name, frames)

        def loader() -> Any:
            if "loaded" not in state:
                tally.variant = tally.variant or self._variant()
                state["loaded"] = spec.load(int(self.data_cfg.width), int(self.data_cfg.height),
                                            self._settings()["max_depth"], int(self.data_cfg.segments))
            return state["loaded"]

        if not force and self._rendered_already(spec, frames, order, verify):  # read only: no lock, no write
            tally.reused.update(b for _ in frames for b in order if b in want)
            if position is not None:
                log.info("render %s scene %s: 0 of its %d frames here need rendering (%s)", position, name,
                         len(frames), ",".join(order))
            return
        with self._scene_lock(name):
            man = self._open_manifest(spec, loader)
            quality = self._quality_cfg()
            if quality is None:
                man.pop("ref_quality", None)
            elif self._pilot_stale(spec, man, quality):
                tally.variant = tally.variant or self._variant()
                man["ref_quality"] = {"key": self._pilot_key(man, quality),
                                      "exposure": self._pilot_exposure(spec),
                                      **self._pilot(spec, man, loader(), quality)}
                tally.msamples += man["ref_quality"]["samples"] / 1e6
            self._fill_scales(spec, man)
            self._save(name, man)
            self._remove_stale_temps(name)
        seen = {(f, b): man["files"].get(f"{f:04d}/{b}.exr") for f in frames for b in order}
        todo = {f: [b for b in order if force or not self._is_done(man, name, f, b, verify)] for f in frames}
        for f in frames:
            tally.reused.update(b for b in order if b not in todo[f] and b in want)
        work = [f for f in frames if todo[f]]
        if position is not None:
            log.info("render %s scene %s: %d of its %d frames here need rendering (%s)", position, name,
                     len(work), len(frames), ",".join(order))
        if not work:
            return
        tally.variant = tally.variant or self._variant()
        frame = _FrameRenderer(self, spec, loader, seen, want, tally)
        t0, done, total = time.perf_counter(), 0, len(work)

        def report(f: int) -> None:
            nonlocal done
            done += 1
            if position is not None:
                dt = time.perf_counter() - t0
                log.info("render %s scene %s: frame %d done (%d/%d); %.2f Msamples/s; elapsed %s, ETA %s",
                         position, name, f, done, total, frame.samples / 1e6 / max(dt, 1e-9),
                         _clock(dt), _clock(dt / done * (total - done)))

        if spec.exposure == "auto" and man.get("exposure") is None and any(
            f != 0 and "ref" in todo[f] and self._quality_frame(man, f) for f in work
        ):
            frame.run(0, todo.get(0, ["ref"]), blocking=True)
            if 0 in work:  # this process's frame 0, rendered first for the auto exposure
                report(0)
            work = [f for f in work if f != 0]
            todo.pop(0, None)
        pending = list(work)

        while pending:
            for f in list(pending):
                if frame.run(f, todo[f], blocking=False):  # False: another process renders it; take it last
                    pending.remove(f)
                    report(f)
            if pending:  # every frame left was busy when tried: wait for the first
                f = pending.pop(0)
                frame.run(f, todo[f], blocking=True)
                report(f)
        tally.msamples += frame.samples / 1e6

    def _rendered_already(self, spec: SceneSpec, frames: list[int], order: list[str], verify: bool) -> bool:
        """Whether every file of ``frames`` x ``order`` of the scene is rendered for this config and the
        manifest needs no change (cameras, reference-quality pilot, scales, settings as the locked path of
        :meth:`_ensure_scene` would leave them; no temp file of a killed writer), found by reading alone: such
        a scene is reused without taking ``<scene>/.lock`` or writing anything, so a fully rendered store on a
        read-only mount is trained from (``mcd.run`` died on an OSError taking the lock)."""
        folder = self.root / spec.name
        path = self.manifest_path(spec.name)
        if not path.is_file() or any(folder.glob(".*.tmp*")) or any(folder.glob("*/.*.tmp*")):
            return False
        try:
            on_disk = self._read_manifest(path)
        except CorruptManifestError:
            return False
        source = spec.source()
        if (on_disk.get("camera_key") != self._camera_key(spec, source)
                or on_disk.get("version") != MANIFEST_VERSION or reads_changed(on_disk, source)):
            return False
        man = copy.deepcopy(on_disk)
        man["source"], man["settings"] = source, self._settings()
        quality = self._quality_cfg()
        if quality is None:
            man.pop("ref_quality", None)
        elif self._pilot_stale(spec, man, quality):
            return False
        self._fill_scales(spec, man)
        if man != upgraded(on_disk, man):
            return False
        return all(self._is_done(man, spec.name, f, b, verify) for f in frames for b in order)

    @contextlib.contextmanager
    def _scene_lock(self, scene: str) -> Iterator[None]:
        """Hold ``<scene>/.lock`` (:func:`mcd.core.file_lock.exclusive`) for a short read-modify-write of the
        scene's manifest.

        Every writer of the scene's manifest holds it, so a process that takes it reads the manifest every
        other process left and loses none of their entries; the manifest's own temp files (``.*.tmp*`` beside
        it, left by a killed run) are removed under it.
        """
        folder = self.root / scene
        lock = self._check_scene_lock(scene)
        with file_lock.exclusive(lock):
            for stale in folder.glob(".*.tmp*"):  # of a killed run
                stale.unlink(missing_ok=True)
            yield

    def _check_scene_lock(self, scene: str) -> Path:
        """``<scene>/.lock``; RuntimeError naming it and its fix when it is not a regular file or is a
        symbolic link (checked before any work, also where the scene is reused without taking it)."""
        lock = self.root / scene / ".lock"
        if lock.is_symlink() or (lock.exists() and not lock.is_file()):
            raise RuntimeError(f"{lock}: the scene's lock file is not a regular file; remove it (`rm -r "
                               f"{lock}`, after checking it holds nothing you need) and run again")
        return lock

    def _check_frame_folders(self, scene: str, frames: list[int]) -> None:
        """RuntimeError naming the path and its fix, before anything is rendered, when a frame's folder
        (``<scene>/<frame>``) is not a folder or its lock (``<scene>/<frame>/.lock``) is not a regular file:
        the frame could be neither locked nor written."""
        for f in frames:
            folder = self.root / scene / f"{f:04d}"
            if (folder.exists() or folder.is_symlink()) and not folder.is_dir():
                raise RuntimeError(f"{folder}: frame {f}'s folder is a file, not a folder; move it away (or "
                                   f"`rm {folder}`, after checking it holds nothing you need) and run again")
            lock = folder / ".lock"
            if lock.is_symlink() or (lock.exists() and not lock.is_file()):
                raise RuntimeError(f"{lock}: frame {f}'s lock file is not a regular file; remove it (`rm -r "
                                   f"{lock}`, after checking it holds nothing you need) and run again")

    @contextlib.contextmanager
    def _frame_lock(self, scene: str, frame: int, blocking: bool) -> Iterator[bool]:
        """Hold ``<scene>/<frame>/.lock`` while this process renders the frame's files; yields False (and
        holds nothing) when another process holds it and `blocking` is off. Under it no other process writes
        in the frame's folder, so temp files there (``.*.tmp*``, of a killed run) are removed."""
        folder = self.root / scene / f"{frame:04d}"
        with file_lock.exclusive(folder / ".lock", blocking=blocking) as lock_file:
            if lock_file is None:
                yield False
                return
            for stale in folder.glob(".*.tmp*"):
                stale.unlink(missing_ok=True)
            yield True

    def _remove_stale_temps(self, scene: str) -> None:
        """Remove the temp files of killed runs in the scene's frame folders that no live writer holds."""
        for folder in sorted({p.parent for p in (self.root / scene).glob("*/.*.tmp*")}):
            if folder.name.isdigit():
                with self._frame_lock(scene, int(folder.name), blocking=False):
                    pass

    def _merge(self, spec: SceneSpec, man: dict, rels: list[str], scales: dict[str, Any]) -> None:
        """Add this process's entries `rels` of `man` (and the manifest-level `scales` it set) to the scene's
        manifest as it is on disk now, under the scene lock (see :meth:`_ensure_scene`)."""
        with self._scene_lock(spec.name):
            disk = self._read_manifest(self.manifest_path(spec.name))
            if disk.get("camera_key") != man.get("camera_key"):
                raise RuntimeError(
                    f"{self.manifest_path(spec.name)}: another render with other camera settings rewrote "
                    f"this manifest while this one rendered; render with one config per store "
                    f"({self.render_command()})")
            disk["files"].update({rel: man["files"][rel] for rel in rels})
            disk.update(scales)
            self._fill_scales(spec, disk)
            self._save(spec.name, disk)

    def _variant(self) -> str:
        from mcd.data.mitsuba_env import select_variant

        return select_variant(str(self.render_cfg.get("variant", "auto")))

    def _render_frame(
        self, spec: SceneSpec, man: dict, f: int, bufs: list[str], r: Any, rendered: Counter[str]
    ) -> dict[str, Any]:
        """Render and write `bufs` of frame `f` with renderer `r`, adding their entries to ``man["files"]``;
        return the manifest-level values it set (``exposure`` from frame 0's reference, ``depth_scale`` from
        frame 0's depth, ``variant``)."""
        import mitsuba as mi

        s = self._settings()
        scales: dict[str, Any] = {"variant": mi.variant()}
        cam = man["cameras"][f]
        r.set_camera(np.asarray(cam["to_world"], dtype=np.float64))
        gb: dict[str, np.ndarray] | None = None
        for b in bufs:
            seed = derive_seed(s["seed"], spec.name, f, b)
            extra: dict[str, Any] = {}
            halves: list[np.ndarray] | None = None
            if b == "ref" and self._quality_frame(man, f):
                spp = self._ref_spp(man, f)
                halves = [r.color(spp // 2, derive_seed(seed, "half", k)) for k in (0, 1)]
                img = (halves[0] + halves[1]) / 2
            elif b in COLOUR_BUFFERS:
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
            if f == 0 and b == "ref":  # before the estimate, which is taken on exposed images
                self._set_exposure(spec, man, img)
                scales["exposure"] = man["exposure"]
                scales["exposure_target"] = man.get("exposure_target")
            if halves is not None:
                extra["psnr_estimate"] = round(estimate_psnr(*halves, float(man["exposure"] or 1.0)), 3)
            self._write(spec.name, man, f, b, img, spp, seed, mi.variant(), extra)
            rendered[b] += 1
            if f == 0 and b == "depth":
                man["depth_scale"] = scales["depth_scale"] = depth_scale(img)
        return scales

    def _fill_scales(self, spec: SceneSpec, man: dict) -> None:
        """Exposure and depth scale from frame 0 when unknown (e.g. files kept from an older manifest); an
        auto exposure also when the manifest's was set for another ``data.exposure_target`` or was a fixed
        one (its ``exposure_target``: what it was set for; a manifest from before the key has its exposure
        computed again from frame 0's reference, the same value for the same target). No file depends on the
        exposure (it is applied at load), so nothing is rendered again: a store rendered at one target kept
        its exposure for every later target, and a run trained on data exposed for the old one while its
        record named the new."""
        if spec.exposure != "auto":
            man["exposure"] = float(spec.exposure)
            man.pop("exposure_target", None)
        elif "0000/ref.exr" in man["files"] and (man.get("exposure") is None
                                                 or man.get("exposure_target") != self._exposure_target()):
            self._set_exposure(spec, man, read_exr(self.path(spec.name, 0, "ref"), self.fix_command("ref")))
        if man.get("depth_scale") is None and "0000/depth.exr" in man["files"]:
            man["depth_scale"] = depth_scale(
                read_exr(self.path(spec.name, 0, "depth"), self.fix_command("depth"))
            )

    def _exposure_target(self) -> float:
        """``data.exposure_target``: the mean of frame 0's reference after an auto exposure."""
        return float(self.data_cfg.get("exposure_target", 0.5))

    def _set_exposure(self, spec: SceneSpec, man: dict, ref0: np.ndarray) -> None:
        if spec.exposure != "auto":
            man["exposure"] = float(spec.exposure)
            man.pop("exposure_target", None)
            return
        exposure = auto_exposure(ref0, self._exposure_target(), str(self.path(spec.name, 0, "ref")))
        man["exposure"] = exposure or 1.0
        man["exposure_target"] = self._exposure_target()
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
        extra: dict[str, Any] | None = None,
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
            **(extra or {}),
        }

    def _save(self, scene: str, man: dict) -> None:
        atomic_write_json(self.manifest_path(scene), man)


@dataclass
class _Tally:
    """What one :meth:`StoreBuilder.ensure` call rendered and reused, its Msamples and Mitsuba variant."""

    rendered: Counter[str] = field(default_factory=Counter)
    reused: Counter[str] = field(default_factory=Counter)
    msamples: float = 0.0
    variant: str | None = None


class _FrameRenderer:
    """One process's renders of one scene's frames, each under the frame's lock (step 3 of
    :meth:`StoreBuilder._ensure_scene`). `seen` holds the manifest entries the process saw when it chose what
    to render: an entry that differs under the lock was written by another process since."""

    def __init__(self, store: StoreBuilder, spec: SceneSpec, loader: Callable[[], Any],
                 seen: dict[tuple[int, str], Any], want: set[str], tally: _Tally):
        self.store, self.spec, self.loader = store, spec, loader
        self.seen, self.want, self.tally = seen, want, tally
        self._renderer: Any = None

    @property
    def samples(self) -> float:
        """Samples this process rendered so far for the scene."""
        return 0.0 if self._renderer is None else float(self._renderer.samples_rendered)

    def run(self, f: int, bufs: list[str], blocking: bool) -> bool:
        """Render what of `bufs` frame `f` still lacks and merge the entries; False (nothing done) when
        another process holds the frame and `blocking` is off."""
        store, name = self.store, self.spec.name
        with store._frame_lock(name, f, blocking) as held:
            if not held:
                return False
            man = store._read_manifest(store.manifest_path(name))
            now = []
            for b in bufs:
                changed = man["files"].get(f"{f:04d}/{b}.exr") != self.seen.get((f, b))
                if changed and store._is_done(man, name, f, b, verify=False):
                    self.tally.reused.update([b] if b in self.want else [])
                else:
                    now.append(b)
            if now:
                if self._renderer is None:
                    from mcd.data.renderer import SceneRenderer

                    s, loaded = store._settings(), self.loader()
                    self._renderer = SceneRenderer(loaded.scene, s["width"], s["height"], loaded.fov,
                                                   s["max_samples_per_pass"])
                scales = store._render_frame(self.spec, man, f, now, self._renderer, self.tally.rendered)
                store._merge(self.spec, man, [f"{f:04d}/{b}.exr" for b in now], scales)
        return True


def _clock(seconds: float) -> str:
    """``H:MM:SS`` of a duration."""
    s = int(round(seconds))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}"


def _fmt(c: Counter[str]) -> str:
    if not c:
        return "nothing"
    return ", ".join(f"{b} x{c[b]}" for b in BUFFERS if c.get(b))
