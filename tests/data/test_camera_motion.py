"""Camera paths and motion vectors: slerp paths, Mitsuba's pixel convention, motion against known
moves.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mcd.data.camera import Camera, backward_motion, interpolate_path, look_at, yaw
from mcd.data.scenes import ray_distances


def test_path_interpolates_positions_linearly_and_orientations_by_slerp():
    a = look_at([0, 0, 0], [0, 0, 1], [0, 1, 0])
    b = yaw(a, 90.0)
    b[:3, 3] = [2.0, 0.0, 4.0]
    c = look_at([2, 1, 4], [3, 1, 4], [0, 1, 0])
    mats = interpolate_path([a, b, c], frames_per_segment=4)
    assert len(mats) == 8
    assert np.allclose(mats[0], a) and np.allclose(mats[4], b)
    assert np.allclose(mats[2][:3, 3], [1.0, 0.0, 2.0])  # halfway: linear position
    half = Rotation.from_matrix(mats[2][:3, :3])
    angle = (half.inv() * Rotation.from_matrix(a[:3, :3])).magnitude()
    assert angle == pytest.approx(np.radians(45.0), abs=1e-6)  # halfway: half the rotation (slerp)
    for m in mats:
        assert np.allclose(m[:3, :3].T @ m[:3, :3], np.eye(3), atol=1e-9)


def test_look_at_and_pixel_rays_match_mitsuba(cbox32):
    import mitsuba as mi

    m = look_at([1, 2, 3], [0.5, 1.5, 0], [0, 1, 0])
    ref = mi.ScalarTransform4f().look_at(origin=[1, 2, 3], target=[0.5, 1.5, 0], up=[0, 1, 0])
    assert np.allclose(m, np.asarray(ref.matrix), atol=1e-6)

    _, r = cbox32
    cam = Camera(np.asarray(m), r.fov, 32, 24)
    sensor = mi.load_dict(
        {
            "type": "perspective",
            "fov": r.fov,
            "fov_axis": "x",
            "to_world": mi.ScalarTransform4f(m.astype(np.float32)),
            "film": {"type": "hdrfilm", "width": 32, "height": 24},
        }
    )
    ys, xs = np.mgrid[0:24, 0:32]
    pos = np.stack([(xs.ravel() + 0.5) / 32, (ys.ravel() + 0.5) / 24])
    ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(pos[0], pos[1]), mi.Point2f(0.5, 0.5))
    d = np.stack([np.asarray(ray.d.x), np.asarray(ray.d.y), np.asarray(ray.d.z)], -1).reshape(24, 32, 3)
    assert np.allclose(cam.pixel_directions(), d, atol=1e-5)
    px, front = cam.project(cam.origin + 3.0 * d)
    assert front.all() and np.allclose(px, np.stack([xs + 0.5, ys + 0.5], -1), atol=1e-3)


def test_motion_of_a_known_translation_against_a_plane():
    w, h, fov, dist, shift = 40, 30, 60.0, 5.0, 0.25
    prev = Camera(look_at([0, 0, -dist], [0, 0, 0], [0, 1, 0]), fov, w, h)
    cur = Camera(look_at([shift, 0, -dist], [shift, 0, 0], [0, 1, 0]), fov, w, h)
    dirs = cur.pixel_directions()
    depth = dist / dirs[..., 2]  # distance along each ray to the plane z = 0
    motion = backward_motion(depth, cur, prev)
    expected = -shift * w / (2 * dist * np.tan(np.radians(fov) / 2))  # camera moved along +x = its left
    assert np.allclose(motion[..., 0], expected, atol=1e-4) and np.allclose(motion[..., 1], 0, atol=1e-4)


def test_rotation_motion_is_depth_independent_and_sky_moves_at_infinity():
    prev = Camera(look_at([0, 0, 0], [0, 0, 1], [0, 1, 0]), 50.0, 32, 32)
    cur = Camera(yaw(prev.to_world, 3.0), 50.0, 32, 32)
    near = backward_motion(np.full((32, 32), 2.0), cur, prev)
    sky = backward_motion(np.zeros((32, 32)), cur, prev)  # depth 0 = no hit
    assert np.allclose(near, sky, atol=1e-4)
    assert (near[..., 0] < 0).all()  # turned left: the content was further left before


def test_aov_depth_is_distance_along_the_pixel_ray(cbox32):
    scene, r = cbox32
    cam = r.camera(r.to_world)
    depth = r.gbuffer(64, seed=1)["depth"][..., 0]
    dirs = cam.pixel_directions().reshape(-1, 3)
    exact = ray_distances(scene, np.repeat(cam.origin[None], len(dirs), 0), dirs).reshape(32, 32)
    hit = np.isfinite(exact)
    assert hit.mean() > 0.8
    rel = np.abs(depth[hit] - exact[hit]) / exact[hit]
    assert np.median(rel) < 0.01  # box-filtered mean over the pixel vs. the centre ray: equal on flat areas


def test_store_motion_maps_pixels_to_the_previous_frame(cbox_store):
    _, store = cbox_store
    errs_warp, errs_still = [], []
    for f in range(1, store.frame_count("cbox")):
        cur, prev = store.load("cbox", f, "ref"), store.load("cbox", f - 1, "ref")
        mv = store.load("cbox", f, "motion")
        h, w = mv.shape[:2]
        ys, xs = np.mgrid[0:h, 0:w]
        sx, sy = xs + mv[..., 0], ys + mv[..., 1]
        x0, y0 = np.floor(sx).astype(int), np.floor(sy).astype(int)
        ok = (x0 >= 0) & (y0 >= 0) & (x0 < w - 1) & (y0 < h - 1)
        x0c, y0c = np.clip(x0, 0, w - 2), np.clip(y0, 0, h - 2)
        ax, ay = (sx - x0)[..., None], (sy - y0)[..., None]
        warped = (
            (1 - ax) * (1 - ay) * prev[y0c, x0c]
            + ax * (1 - ay) * prev[y0c, x0c + 1]
            + (1 - ax) * ay * prev[y0c + 1, x0c]
            + ax * ay * prev[y0c + 1, x0c + 1]
        )
        assert np.abs(mv[ok]).max() > 0.3  # the camera does move
        errs_warp.append(np.abs(warped - cur)[ok].mean())
        errs_still.append(np.abs(prev - cur)[ok].mean())
    assert np.mean(errs_warp) < 0.6 * np.mean(errs_still)
