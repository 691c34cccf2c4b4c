"""Scenes as Hydra configs (conf/scene/): a Mitsuba XML file or a procedural room, plus its camera path.

A scene config (``data.scenes.<name>``, composed from ``conf/scene/<file>.yaml``) is either

- ``kind: xml``: ``file`` relative to the repository's ``scenes/`` folder when ``vendored: true``, an absolute
  path, or relative to ``paths.scenes_dir`` (env ``MCD_SCENES_DIR``; needed only for the scenes that are not
  vendored, docs/scenes.md); loaded with ``mi.load_file(file, resx, resy, max_depth)`` (a scene that declares
  those ``<default>``s takes them; docs/scenes.md, "Your own scene"); or
- ``kind: procedural``: a room from :mod:`mcd.data.procedural` with its ``seed``.

The camera path (docs/benchmark.md, "Camera"): explicit key nodes ``path.nodes``
(``origin``/``target``/``up``), or derived from the scene's own camera (XML scenes): the first node is that
camera; the others dolly forward by a fraction ``path.dolly`` of the free distance ahead, truck sideways by
``path.truck`` of the free distance to the side, and pan by alternating ``path.pan_deg``. Every segment is
checked against the scene's geometry (a ray from node to node must not hit anything), so that no frame is
rendered from inside a wall.

Scenes by path (docs/scenes.md): an entry of ``data.train_scenes`` / ``transfer_scenes`` / ``test_scenes``
that names an ``.xml`` file is registered by :func:`register_paths` as an XML scene (its name: the file's
stem, or its folder's name for ``scene.xml``), with the derived camera path and ``exposure: auto``.
"""

from __future__ import annotations

import hashlib
import json
import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from omegaconf import DictConfig, OmegaConf

from mcd.core.paths import VENDORED_SCENES_DIR
from mcd.core.paths import scenes_dir as resolve_scenes_dir
from mcd.data.camera import look_at, yaw

log = logging.getLogger(__name__)

VENDORED_DIR = VENDORED_SCENES_DIR


class SceneNotFoundError(FileNotFoundError):
    """A scene file is missing; the message names the path and the setting that moves it."""


@dataclass
class SceneSpec:
    """One registered scene, resolved from its config."""

    name: str
    kind: str
    file: Path | None = None
    seed: int = 0
    room: dict[str, Any] = field(default_factory=dict)
    path: dict[str, Any] = field(default_factory=dict)
    exposure: float | str = "auto"
    missing_hint: str = ""

    @staticmethod
    def from_cfg(name: str, scfg: DictConfig | dict, scenes_dir: str | Path | None) -> SceneSpec:
        d = OmegaConf.to_container(scfg, resolve=True) if isinstance(scfg, DictConfig) else dict(scfg)
        kind = d.get("kind")
        if kind == "xml":
            rel = d.get("file")
            if not rel:
                raise ValueError(f"scene {name!r}: kind xml needs a 'file' (conf/scene/)")
            file: Path | None
            if d.get("vendored", False):
                file = VENDORED_DIR / rel
                hint = f"the repository's scenes/ folder ({VENDORED_DIR}) should hold it: restore it from git"
            elif Path(rel).expanduser().is_absolute():
                file = Path(rel).expanduser()
                hint = f"check the path data.scenes.{name}.file={rel}"
            else:
                hint = (
                    f"set paths.scenes_dir=<dir> or the environment variable MCD_SCENES_DIR to the folder "
                    f"that holds {rel} (now {scenes_dir!r}); docs/scenes.md says where to get each scene"
                )
                base = resolve_scenes_dir(scenes_dir)
                file = None if base is None else base / rel
            return SceneSpec(
                name,
                "xml",
                file=file,
                path=d.get("path") or {},
                exposure=d.get("exposure", "auto"),
                missing_hint=hint,
            )
        if kind == "procedural":
            return SceneSpec(
                name,
                "procedural",
                seed=int(d.get("seed", 0)),
                room=d.get("room") or {},
                path=d.get("path") or {},
                exposure=d.get("exposure", "auto"),
            )
        raise ValueError(f"scene {name!r}: unknown kind {kind!r} (expected 'xml' or 'procedural')")

    def check_exists(self) -> None:
        """Raise SceneNotFoundError naming the path and how to fix it."""
        if self.kind == "xml" and self.file is None:
            raise SceneNotFoundError(f"scene {self.name!r} is not vendored in the repository and no scenes "
                                     f"folder is set: {self.missing_hint}")
        if self.kind == "xml" and not self.file.is_file():
            what = "is a folder, not a scene file" if self.file.is_dir() else "not found"
            raise SceneNotFoundError(f"scene {self.name!r}: file {self.file} {what}; {self.missing_hint}")

    def check_readable(self) -> None:
        """:meth:`check_exists`, then ValueError naming the file where an XML scene is not well-formed XML or
        declares no ``<sensor>`` (and includes no other file that could): Mitsuba's parser error, or an
        IndexError for the missing camera, came only when the scene's turn to render came, after the scenes
        before it had rendered. Reads the XML only (no Mitsuba)."""
        self.check_exists()
        if self.kind != "xml":
            return
        import xml.etree.ElementTree as ET

        try:
            root = ET.parse(self.file).getroot()
        except ET.ParseError as err:
            raise ValueError(f"scene {self.name!r}: {self.file} is not well-formed XML ({err}); a Mitsuba 3 "
                             "scene file is XML: fix or replace it (docs/scenes.md)") from None
        tags = {el.tag for el in root.iter()}
        if "sensor" not in tags and "include" not in tags:
            raise ValueError(f"scene {self.name!r}: {self.file} declares no <sensor> (the camera every frame "
                             "is rendered from): add one (docs/scenes.md)")

    def source(self) -> dict[str, Any]:
        """What the scene is made of, with a hash: recorded in the manifest; a change invalidates renders. An
        XML scene's ``sha256`` is its file's; ``reads`` hashes the files it reads besides
        (:func:`scene_reads`:
        meshes, textures, included XML), which :class:`mcd.data.store_builder.StoreBuilder` compares apart,
        so that stores rendered before the key keep their renders."""
        if self.kind == "xml":
            self.check_exists()
            h = file_sha256(self.file)
            return {"kind": "xml", "file": str(self.file), "sha256": h, "path": self.path,
                    "reads": reads_digest(self.file)}
        from mcd.data.procedural import GENERATOR_VERSION

        desc = {
            "kind": "procedural",
            "seed": self.seed,
            "room": self.room,
            "path": self.path,
            "generator_version": GENERATOR_VERSION,
        }
        desc["sha256"] = hashlib.sha256(json.dumps(desc, sort_keys=True).encode()).hexdigest()
        return desc

    def load(self, width: int | None, height: int | None, max_depth: int | None,
             segments: int) -> LoadedScene:
        """Load into Mitsuba (the variant must be set) and build the camera key nodes (``segments + 1``). A
        ``width`` / ``height`` of None keeps the film size the scene file declares (its sensor's film).

        ``optimize=False``: Mitsuba's shape merging orders the emitters differently from process to process,
        so the same seed would not reproduce a render (docs/data.md, "Reproducible renders").
        """
        import mitsuba as mi

        if self.kind == "xml":
            self.check_exists()
            kwargs: dict[str, Any] = {k: v for k, v in (("resx", width), ("resy", height)) if v is not None}
            if max_depth is not None:
                kwargs["max_depth"] = max_depth
            declared = declared_defaults(self.file)
            if "max_depth" in kwargs and "max_depth" not in declared:
                log.info("scene %s declares no <default name=\"max_depth\">: its integrator's own depth is "
                         "used", self.name)
            scene = mi.load_file(str(self.file), optimize=False,
                                 **{k: v for k, v in kwargs.items() if k in declared})
            sensor = scene.sensors()[0]
            params = mi.traverse(sensor)
            fov = float(np.asarray(params["x_fov"], dtype=np.float64).ravel()[0])
            cam0 = np.asarray(params["to_world"].matrix, dtype=np.float64).reshape(4, 4, -1)[..., 0]
            if self.path.get("nodes"):
                nodes = [look_at(n["origin"], n["target"], n["up"]) for n in self.path["nodes"]]
            else:
                nodes = derive_nodes(scene, cam0, segments, self.path)
        else:
            from mcd.data.procedural import build_room

            scene_dict, nodes, fov = build_room(self.seed, self.room, segments, max_depth or 8)
            scene = mi.load_dict(scene_dict, optimize=False)
        if len(nodes) != segments + 1:
            raise ValueError(
                f"scene {self.name!r}: path has {len(nodes)} key nodes, the profile needs {segments + 1}"
            )
        check_segments_clear(scene, nodes, self.name)
        return LoadedScene(self, scene, nodes, fov)


def declared_defaults(file: Path) -> set[str]:
    """Names of the ``<default>`` parameters a Mitsuba scene file declares (Mitsuba refuses others).

    The film size of a scene without ``resx``/``resy`` does not matter (every render uses the store's own
    sensor, :mod:`mcd.data.renderer`); a file that is not well-formed XML yields none, and Mitsuba's loader
    then reports the error.
    """
    import xml.etree.ElementTree as ET

    try:
        root = ET.parse(file).getroot()
    except ET.ParseError:
        return set()
    return {str(d.get("name")) for d in root.iter("default")}


@dataclass
class LoadedScene:
    spec: SceneSpec
    scene: Any  # mi.Scene
    nodes: list[np.ndarray]
    fov: float


def ray_distances(scene: Any, origins: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Distance to the first hit along each ray (inf for a miss); `origins`, `dirs` are ``(N, 3)``."""
    import drjit as dr
    import mitsuba as mi

    o = np.asarray(origins, dtype=np.float32)
    d = np.asarray(dirs, dtype=np.float32)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    ray = mi.Ray3f(mi.Point3f(*[o[:, i] for i in range(3)]), mi.Vector3f(*[d[:, i] for i in range(3)]))
    si = scene.ray_intersect(ray)
    t = np.asarray(dr.select(si.is_valid(), si.t, dr.inf), dtype=np.float64)
    return np.atleast_1d(t)


def derive_nodes(scene: Any, cam0: np.ndarray, segments: int, path: dict[str, Any]) -> list[np.ndarray]:
    """Key nodes from the scene's own camera: dolly forward, truck sideways and pan, staying in free space."""
    dolly = float(path.get("dolly", 0.3))
    truck = float(path.get("truck", 0.15))
    pan = float(path.get("pan_deg", 10.0))
    rot = cam0[:3, :3] / np.linalg.norm(cam0[:3, :3], axis=0, keepdims=True)
    o, left, fwd = cam0[:3, 3], rot[:, 0], rot[:, 2]
    ahead = float(ray_distances(scene, o[None], fwd[None])[0])
    if not np.isfinite(ahead):
        ahead = 1.0
    nodes = [cam0.copy()]
    for i in range(1, segments + 1):
        a = i / segments
        p = o + fwd * dolly * ahead * a
        side = 1.0 if i % 2 else -1.0
        free = float(ray_distances(scene, p[None], (side * left)[None])[0])
        free = free if np.isfinite(free) else ahead
        p = p + side * left * truck * free * a
        m = yaw(cam0, side * pan)
        m[:3, 3] = p
        nodes.append(m)
    return nodes


def check_segments_clear(scene: Any, nodes: list[np.ndarray], name: str) -> None:
    """Raise if a straight move between consecutive key nodes passes through geometry."""
    for k in range(len(nodes) - 1):
        a, b = nodes[k][:3, 3], nodes[k + 1][:3, 3]
        seg = float(np.linalg.norm(b - a))
        if seg < 1e-9:
            continue
        hit = float(ray_distances(scene, a[None], (b - a)[None])[0])
        if hit <= seg:
            raise ValueError(
                f"scene {name!r}: the camera path between key nodes {k} and {k + 1} passes through geometry "
                f"(hit at {hit:.3g} of {seg:.3g}); set data.scenes.{name}.path.dolly / truck / pan_deg, or "
                "explicit path.nodes (docs/scenes.md, 'Camera paths')"
            )


SCENE_LISTS = ("train_scenes", "transfer_scenes", "test_scenes")


def scene_reads(file: Path) -> list[Path]:
    """The files an XML scene reads besides itself: each ``filename`` its elements name (``<include
    filename>``, ``<string name="filename" value>``), found beside the file that names it or beside the scene
    file (Mitsuba's file resolver), and the files the included XML reads in turn; a value holding a ``$``
    parameter is left out (its value is Mitsuba's). A file not found is listed by its path as named."""
    import xml.etree.ElementTree as ET

    found: dict[Path, None] = {}
    todo = [file]
    while todo:
        xml = todo.pop()
        try:
            root = ET.parse(xml).getroot()
        except (OSError, ET.ParseError):
            continue
        for el in root.iter():
            name = el.get("filename") if el.tag == "include" else (
                el.get("value") if el.get("name") == "filename" else None)
            if not name or "$" in name:
                continue
            candidates = (xml.parent / name, file.parent / name)
            path = next((c for c in candidates if c.is_file()), candidates[0])
            if path not in found and path != file:
                found[path] = None
                if path.suffix == ".xml" and path.is_file():
                    todo.append(path)
    return list(found)


#: :func:`file_sha256`'s digests in this process, by (resolved path, mtime in ns, size in bytes).
_DIGESTS: dict[tuple[str, int, int], str] = {}


def file_sha256(path: Path) -> str:
    """The SHA-256 of ``path``'s bytes, hashed once per process while the file keeps its modification time
    and size: a scene's source (:meth:`SceneSpec.source`) is asked for several times per scene and run (the
    store's reuse check, its manifest, the packer's check), and its XML, meshes and textures can be tens of
    MB. A file edited or replaced since (a new mtime or size) is hashed again; an edit that keeps both (the
    same size within one tick of the file system's clock) is not seen until the next process."""
    st = path.stat()
    key = (str(path.resolve()), st.st_mtime_ns, st.st_size)
    if (digest := _DIGESTS.get(key)) is None:
        h = hashlib.sha256()
        with open(path, "rb") as f:
            while chunk := f.read(1 << 20):
                h.update(chunk)
        digest = _DIGESTS[key] = h.hexdigest()
    return digest


def reads_digest(file: Path) -> str:
    """SHA-256 over the files :func:`scene_reads` lists (each its path relative to the scene's folder and its
    bytes' SHA-256; ``missing`` for one not found)."""
    lines = []
    for path in scene_reads(file):
        digest = file_sha256(path) if path.is_file() else "missing"
        try:
            rel = path.relative_to(file.parent).as_posix()
        except ValueError:
            rel = str(path)
        lines.append(f"{rel} {digest}")
    return hashlib.sha256("\n".join(sorted(lines)).encode()).hexdigest()


def path_scene_name(file: str | Path) -> str:
    """The name a scene given by path is registered under: its folder's name for ``scene.xml``, else its
    stem."""
    p = Path(file)
    return p.parent.resolve().name if p.stem == "scene" else p.stem


def register_paths(cfg: DictConfig) -> DictConfig:
    """Register every ``.xml`` entry of ``cfg.data``'s scene lists as a scene and name it in the lists, in
    place.

    ``data.test_scenes=[~/scenes/kitchen/scene.xml]`` becomes ``data.scenes.kitchen = {kind: xml, file:
    <absolute path>, exposure: auto}`` and ``data.test_scenes=[kitchen]`` (relative paths are taken from the
    working directory). A name already registered for another file is an error naming both.
    """
    from omegaconf import open_dict

    data = cfg.data
    with open_dict(cfg):
        for key in SCENE_LISTS:
            entries = list(data.get(key) or [])
            if not any(str(e).endswith(".xml") for e in entries):
                continue
            names = []
            for entry in entries:
                entry = str(entry)
                if not entry.endswith(".xml"):
                    names.append(entry)
                    continue
                file = Path(entry).expanduser().resolve()
                name = path_scene_name(file)
                known = data.scenes.get(name) if data.get("scenes") is not None else None
                if known is not None and str(known.get("file")) != str(file):
                    raise ValueError(f"data.{key}: {entry} would be registered as scene {name!r}, which "
                                     f"already names {known.get('file')}; register it under another name "
                                     f"with '+data.scenes.<name>={{kind: xml, file: {file}}}' "
                                     "(docs/scenes.md)")
                if known is None:
                    if data.get("scenes") is None:
                        data.scenes = {}
                    data.scenes[name] = {"kind": "xml", "file": str(file), "exposure": "auto", "path": {}}
                names.append(name)
            data[key] = names
    return cfg
