"""Procedural interiors: rooms that look like the paper's data (docs/benchmark.md "Data protocol").

``build_room(seed, params, segments, max_depth)`` returns a Mitsuba scene dict, ``segments + 1`` camera key
nodes and the horizontal field of view. A room (Y up, metres) has a floor, a ceiling and four walls; furniture
-like boxes stand on the floor and spheres rest on them or on the floor; every object gets one of the
materials diffuse, rough plastic, rough conductor or dielectric (glass), diffuse colours being plain,
checkerboard or a generated bitmap (value noise, stripes); two or more rectangular area lights of different
sizes hang under the ceiling; with probability ``env_prob`` one wall has a window and a constant sky light
shines through it. The camera moves along the front part of the room (kept free of furniture) and looks into
it, so no frame is inside geometry. Everything derives from ``seed`` (NumPy's PCG64), so a room is
reproducible.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mcd.data.camera import look_at

GENERATOR_VERSION = 1

DEFAULTS: dict[str, Any] = {
    "size": [[4.0, 7.0], [2.6, 3.2], [5.0, 8.0]],  # width (x), height (y), depth (z) ranges
    "boxes": [3, 6],
    "spheres": [2, 4],
    "lights": [2, 3],
    "env_prob": 0.5,
    "light_power": 25.0,  # radiance * area summed over lights, before the per-light split
    "fov": 70.0,
    "texture_res": 64,
}

CONDUCTORS = ("Au", "Cu", "Al", "Ag", "Cr")


def _rect(to_world: np.ndarray, bsdf: dict, emitter: dict | None = None) -> dict:
    import mitsuba as mi

    d = {"type": "rectangle", "to_world": mi.ScalarTransform4f(to_world.astype(np.float32)), "bsdf": bsdf}
    if emitter is not None:
        d["emitter"] = emitter
    return d


def _trs(t: tuple[float, float, float], rot: np.ndarray, s: tuple[float, float, float]) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = rot @ np.diag(s)
    m[:3, 3] = t
    return m


def _rot(axis: str, deg: float) -> np.ndarray:
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _bitmap_texture(rng: np.random.Generator, res: int) -> dict:
    """A generated RGB bitmap: smooth value noise or stripes between two colours."""
    import mitsuba as mi

    c0, c1 = rng.uniform(0.05, 0.85, 3), rng.uniform(0.05, 0.85, 3)
    if rng.random() < 0.5:
        coarse = rng.random((res // 8 + 1, res // 8 + 1))
        t = np.kron(coarse, np.ones((8, 8)))[:res, :res]
        k = np.ones(5) / 5  # soften the blocks
        t = np.apply_along_axis(lambda r: np.convolve(r, k, mode="same"), 0, t)
        t = np.apply_along_axis(lambda r: np.convolve(r, k, mode="same"), 1, t)
    else:
        freq = rng.integers(2, 8)
        y = np.linspace(0, 1, res)[:, None] * np.ones((1, res))
        t = 0.5 + 0.5 * np.sin(2 * np.pi * freq * (y + 0.3 * np.linspace(0, 1, res)[None, :]))
    img = (c0 * (1 - t[..., None]) + c1 * t[..., None]).astype(np.float32)
    return {"type": "bitmap", "bitmap": mi.Bitmap(img), "raw": True, "filter_type": "bilinear"}


def _diffuse_colour(rng: np.random.Generator, res: int) -> dict:
    r = rng.random()
    if r < 0.45:
        return {"type": "rgb", "value": rng.uniform(0.1, 0.85, 3).tolist()}
    if r < 0.75:
        import mitsuba as mi

        scale = float(rng.uniform(2, 10))
        return {
            "type": "checkerboard",
            "color0": {"type": "rgb", "value": rng.uniform(0.05, 0.8, 3).tolist()},
            "color1": {"type": "rgb", "value": rng.uniform(0.05, 0.8, 3).tolist()},
            "to_uv": mi.ScalarTransform4f().scale([scale, scale, 1]),
        }
    return _bitmap_texture(rng, res)


def _material(rng: np.random.Generator, res: int, allow_glass: bool) -> dict:
    r = rng.random()
    if r < 0.4 or (r >= 0.85 and not allow_glass):
        bsdf = {"type": "diffuse", "reflectance": _diffuse_colour(rng, res)}
    elif r < 0.65:
        bsdf = {
            "type": "roughplastic",
            "diffuse_reflectance": _diffuse_colour(rng, res),
            "alpha": float(rng.uniform(0.05, 0.4)),
        }
    elif r < 0.85:
        bsdf = {
            "type": "roughconductor",
            "material": str(rng.choice(CONDUCTORS)),
            "alpha": float(rng.uniform(0.05, 0.4)),
        }
    else:
        return {"type": "dielectric", "int_ior": float(rng.uniform(1.33, 1.6))}
    return {"type": "twosided", "material": bsdf}


def build_room(
    seed: int, params: dict[str, Any] | None, segments: int, max_depth: int
) -> tuple[dict, list[np.ndarray], float]:
    """A procedural room: (Mitsuba scene dict, ``segments + 1`` camera key nodes, horizontal fov in deg)."""
    p = {**DEFAULTS, **(params or {})}
    rng = np.random.default_rng(seed)
    (w0, w1), (h0, h1), (d0, d1) = p["size"]
    W, H, D = float(rng.uniform(w0, w1)), float(rng.uniform(h0, h1)), float(rng.uniform(d0, d1))
    res = int(p["texture_res"])
    scene: dict[str, Any] = {"type": "scene", "integrator": {"type": "path", "max_depth": int(max_depth)}}

    def wall_bsdf() -> dict:
        return {"type": "twosided", "material": {"type": "diffuse", "reflectance": _diffuse_colour(rng, res)}}

    # rectangle: [-1, 1]^2 in the xy plane, normal +z; the room spans x in [-W/2, W/2], y in [0, H],
    # z in [-D/2, D/2]
    scene["floor"] = _rect(_trs((0, 0, 0), _rot("x", -90), (W / 2, D / 2, 1)), wall_bsdf())
    scene["ceiling"] = _rect(_trs((0, H, 0), _rot("x", 90), (W / 2, D / 2, 1)), wall_bsdf())
    scene["wall_left"] = _rect(_trs((-W / 2, H / 2, 0), _rot("y", 90), (D / 2, H / 2, 1)), wall_bsdf())
    scene["wall_right"] = _rect(_trs((W / 2, H / 2, 0), _rot("y", -90), (D / 2, H / 2, 1)), wall_bsdf())
    scene["wall_front"] = _rect(_trs((0, H / 2, D / 2), _rot("y", 180), (W / 2, H / 2, 1)), wall_bsdf())
    back = wall_bsdf()
    env = bool(rng.random() < float(p["env_prob"]))
    if env:  # back wall with a window: four panels around the opening, sky light outside
        wx, wy, ww, wh = float(rng.uniform(-W / 4, W / 4)), float(rng.uniform(1.0, H - 1.0)), W / 5, H / 5
        z = -D / 2
        panels = {
            "back_bottom": ((0, (wy - wh) / 2, z), (W / 2, (wy - wh) / 2)),
            "back_top": ((0, (wy + wh + H) / 2, z), (W / 2, (H - wy - wh) / 2)),
            "back_left": (((-W / 2 + wx - ww) / 2, wy, z), ((wx - ww + W / 2) / 2, wh)),
            "back_right": (((W / 2 + wx + ww) / 2, wy, z), ((W / 2 - wx - ww) / 2, wh)),
        }
        for name, (t, (sx, sy)) in panels.items():
            scene[name] = _rect(_trs(t, np.eye(3), (sx, sy, 1)), back)
        sky = rng.uniform(0.3, 1.0) * np.array([0.6, 0.75, 1.0])
        scene["sky"] = {"type": "constant", "radiance": {"type": "rgb", "value": sky.tolist()}}
    else:
        scene["wall_back"] = _rect(_trs((0, H / 2, -D / 2), np.eye(3), (W / 2, H / 2, 1)), back)

    # furniture in the back part of the room; the front 2 m stay free for the camera
    z_min, z_max = -D / 2 + 0.4, D / 2 - 2.2
    tops: list[tuple[float, float, float, float]] = []
    for i in range(int(rng.integers(p["boxes"][0], p["boxes"][1] + 1))):
        sx, sy, sz = rng.uniform(0.2, 0.6), rng.uniform(0.2, 0.9), rng.uniform(0.2, 0.6)
        x = float(rng.uniform(-W / 2 + sx + 0.1, W / 2 - sx - 0.1))
        z = float(rng.uniform(z_min + sz, max(z_min + sz, z_max - sz)))
        rot = _rot("y", float(rng.uniform(0, 90)))
        import mitsuba as mi

        scene[f"box{i}"] = {
            "type": "cube",
            "to_world": mi.ScalarTransform4f(_trs((x, sy, z), rot, (sx, sy, sz)).astype(np.float32)),
            "bsdf": _material(rng, res, allow_glass=True),
        }
        tops.append((x, 2 * sy, z, min(sx, sz)))
    for i in range(int(rng.integers(p["spheres"][0], p["spheres"][1] + 1))):
        if tops and rng.random() < 0.6:
            x, y, z, half = tops[int(rng.integers(len(tops)))]
            r = float(rng.uniform(0.08, max(0.09, 0.8 * half)))
        else:
            r = float(rng.uniform(0.1, 0.35))
            x, y, z = float(rng.uniform(-W / 2 + r, W / 2 - r)), 0.0, float(rng.uniform(z_min + r, z_max))
        scene[f"sphere{i}"] = {
            "type": "sphere",
            "center": [x, y + r, z],
            "radius": r,
            "bsdf": _material(rng, res, allow_glass=True),
        }

    # two or more area lights of different sizes under the ceiling, facing down
    n_lights = int(rng.integers(p["lights"][0], p["lights"][1] + 1))
    sizes = np.sort(rng.uniform(0.1, 0.7, n_lights))[::-1] * np.linspace(1.0, 0.35, n_lights)
    for i, s in enumerate(sizes):
        area = 4 * s * s
        colour = np.array([1.0, 0.9, 0.75]) if rng.random() < 0.5 else np.array([0.9, 0.95, 1.0])
        radiance = colour * float(p["light_power"]) / n_lights / area
        x, z = (
            float(rng.uniform(-W / 2 + s + 0.2, W / 2 - s - 0.2)),
            float(rng.uniform(-D / 2 + s + 0.2, D / 2 - s - 0.2)),
        )
        scene[f"light{i}"] = _rect(
            _trs((x, H - 0.01, z), _rot("x", 90), (s, s, 1)),
            {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.8, 0.8, 0.8]}},
            {"type": "area", "radiance": {"type": "rgb", "value": radiance.tolist()}},
        )

    # camera: along the free front strip, looking into the room
    nodes = []
    cz = D / 2 - 0.8
    xs = np.linspace(-W / 2 + 0.7, W / 2 - 0.7, segments + 1)
    if rng.random() < 0.5:
        xs = xs[::-1]
    for x in xs:
        y = float(rng.uniform(1.2, min(1.8, H - 0.4)))
        origin = (float(x), y, cz + float(rng.uniform(-0.3, 0.3)))
        target = (float(rng.uniform(-W / 4, W / 4)), float(rng.uniform(0.6, 1.2)), -D / 4)
        nodes.append(look_at(origin, target, (0, 1, 0)))
    import mitsuba as mi

    scene["sensor"] = {
        "type": "perspective",
        "fov": float(p["fov"]),
        "fov_axis": "x",
        "to_world": mi.ScalarTransform4f(nodes[0].astype(np.float32)),
    }
    return scene, nodes, float(p["fov"])
