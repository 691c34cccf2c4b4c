"""A scene's source (:meth:`mcd.data.scenes.SceneSpec.source`, the manifest's record of what a scene is made
of) hashes each file once per process (:func:`mcd.data.scenes.file_sha256`, by path, modification time and
size), and an edited file changes it: the XML's own ``sha256``, a mesh's ``reads``."""

from __future__ import annotations

import hashlib
import os
import shutil

from mcd.data import scenes
from mcd.data.scenes import VENDORED_DIR, SceneSpec, file_sha256


def _spec(folder) -> SceneSpec:
    return SceneSpec.from_cfg("boxm", {"kind": "xml", "file": str(folder / "scene.xml")}, None)


def _touch_later(path) -> None:
    """A modification time 2 s after the file's, so that an edit within one clock tick is seen as one."""
    st = path.stat()
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns + 2_000_000_000))


def test_an_edited_scene_file_changes_the_source(tmp_path):
    shutil.copytree(VENDORED_DIR / "cbox", tmp_path / "boxm")
    xml = tmp_path / "boxm" / "scene.xml"
    spec = _spec(tmp_path / "boxm")
    first = spec.source()
    assert first["sha256"] == hashlib.sha256(xml.read_bytes()).hexdigest()
    assert spec.source() == first  # unchanged files: the same source, from the process's digests

    xml.write_text(xml.read_text() + "<!-- edited -->\n")
    edited = spec.source()
    assert edited["sha256"] == hashlib.sha256(xml.read_bytes()).hexdigest() != first["sha256"]
    assert edited["reads"] == first["reads"]

    # the same size: the new modification time alone asks for a new hash
    text = xml.read_text()
    xml.write_text(text.replace("edited", "EDITED"))
    _touch_later(xml)
    assert spec.source()["sha256"] == hashlib.sha256(xml.read_bytes()).hexdigest() != edited["sha256"]


def test_an_edited_mesh_changes_the_reads(tmp_path):
    shutil.copytree(VENDORED_DIR / "cbox", tmp_path / "boxm")
    spec = _spec(tmp_path / "boxm")
    first = spec.source()
    mesh = tmp_path / "boxm" / "meshes" / "cbox_largebox.obj"
    mesh.write_bytes(mesh.read_bytes().replace(b"v ", b"v  ", 1))
    changed = spec.source()
    assert changed["reads"] != first["reads"] and changed["sha256"] == first["sha256"]


def test_a_file_is_hashed_once_while_unchanged(tmp_path):
    """The digest is kept under the file's path, mtime and size: an unchanged file is not read again (its
    entry is the one ``file_sha256`` made), an edited one gets an entry of its own."""
    path = tmp_path / "mesh.obj"
    path.write_bytes(b"v 0 0 0\n" * 1000)
    digest = file_sha256(path)
    st = path.stat()
    key = (str(path.resolve()), st.st_mtime_ns, st.st_size)
    assert scenes._DIGESTS[key] == digest == hashlib.sha256(path.read_bytes()).hexdigest()
    scenes._DIGESTS[key] = "kept"  # what the process holds is what it answers while the file is unchanged
    assert file_sha256(path) == "kept"
    path.write_bytes(b"v 1 1 1\n" * 1000)
    _touch_later(path)
    assert file_sha256(path) == hashlib.sha256(path.read_bytes()).hexdigest()
    del scenes._DIGESTS[key]
