"""Which part of a profile one render process takes: ``render.shard``, ``render.scenes``, ``render.frames``
(docs/scale.md, "Render in shards"; docs/data.md, "Buffers, seeds, store").

A profile's work is a list of *units*, one per (scene, frame) pair: the scenes sorted by name, each scene's
frames in order. ``render.scenes=[a,b]`` keeps those scenes' units, ``render.frames=a:b`` the frames
``a <= f < b`` (0-based, Python slice syntax, either end may be left out), and ``render.shard=i/N``
(0-based: ``0 <= i < N``; or ``render.shard=i render.shards=N``, the form a Hydra sweep
``'render.shard=range(0,N)'`` writes) deals what is left round-robin over N shards and keeps the i-th's:
unit k goes to shard ``k % N``. The N shards of one selection are disjoint and together cover it, so N
processes or machines given ``0/N`` .. ``N-1/N`` render the selection once; adjacent frames land on different
shards, so every shard gets a like share of every scene (a scene's frames cost alike, scenes do not).

Overlapping selections (two layouts of different N, or a shard run twice) are not an error:
:meth:`mcd.data.store_builder.StoreBuilder.ensure` renders each frame under a per-frame lock and checks the
manifest again under it, so a unit another process has done or is doing is not rendered twice.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

from mcd.core.config_rules import parse_shard

_FRAMES = re.compile(r"^\s*(\d*)\s*:\s*(\d*)\s*$")


@dataclass(frozen=True)
class Selection:
    """A render process's share of a profile (see the module docstring). The default is everything."""

    index: int = 0
    count: int = 1
    scenes: tuple[str, ...] | None = None
    frames: tuple[int, int] | None = None  # [start, stop)

    @classmethod
    def from_render_cfg(cls, render_cfg: Any, scene_names: list[str], n_frames: int) -> Selection:
        """Parse and check ``render.shard``, ``render.scenes`` and ``render.frames`` against the profile's
        scenes and frame count. A ValueError names the key, the value and what to write instead; nothing is
        rendered before this check."""
        get = render_cfg.get if render_cfg is not None else (lambda _k, _d=None: None)
        index, count = parse_shard(get("shard", None), get("shards", None))
        scenes = get("scenes", None)
        if scenes is not None:
            if isinstance(scenes, str) or not all(isinstance(s, str) for s in scenes):
                raise ValueError(f"render.scenes={scenes!r}: expected a list of scene names, e.g. "
                                 f"render.scenes=[{scene_names[0] if scene_names else 'cbox'}]")
            unknown = [s for s in scenes if s not in scene_names]
            if unknown:
                raise ValueError(f"render.scenes: {unknown} not among the scenes this command renders "
                                 f"{scene_names}; pick from those (or leave render.scenes=null for all)")
            if not scenes:
                raise ValueError("render.scenes=[] selects nothing: list scenes or leave it null for all")
            scenes = tuple(scenes)
        frames = parse_frames(get("frames", None), n_frames)
        return cls(index, count, scenes, frames)

    def units(self, scene_names: list[str], n_frames: int) -> dict[str, list[int]]:
        """``{scene: [frames]}`` of this selection's share, scenes in the order of ``scene_names`` (those
        without a unit left out), frames ascending."""
        chosen = sorted(s for s in scene_names if self.scenes is None or s in self.scenes)
        start, stop = self.frames if self.frames is not None else (0, n_frames)
        out: dict[str, list[int]] = {}
        k = 0
        for scene in chosen:
            for f in range(start, stop):
                if k % self.count == self.index:
                    out.setdefault(scene, []).append(f)
                k += 1
        return {s: out[s] for s in scene_names if s in out}

    def is_everything(self) -> bool:
        return self.count == 1 and self.scenes is None and self.frames is None

    def describe(self) -> str:
        """A short text of the selection for log lines, e.g. ``shard 3/64, frames 0:100``."""
        parts = []
        if self.count > 1:
            parts.append(f"shard {self.index}/{self.count}")
        if self.scenes is not None:
            parts.append(f"scenes {','.join(self.scenes)}")
        if self.frames is not None:
            parts.append(f"frames {self.frames[0]}:{self.frames[1]}")
        return ", ".join(parts) or "the whole profile"


def parse_frames(value: Any, n_frames: int) -> tuple[int, int] | None:
    """``render.frames`` (``None``, ``"a:b"``, ``":b"``, ``"a:"`` or one frame number) as ``(a, b)`` within
    ``[0, n_frames]``; a ValueError naming the key and the profile's frame count."""
    if value is None:
        return None
    if isinstance(value, int) and not isinstance(value, bool):
        start, stop = value, value + 1
    else:
        m = _FRAMES.match(str(value))
        if m is None:
            raise ValueError(f"render.frames={value!r}: expected a:b (0-based, b excluded), a:, :b or one "
                             f"frame number; this profile has frames 0:{n_frames}")
        start = int(m.group(1)) if m.group(1) else 0
        stop = int(m.group(2)) if m.group(2) else n_frames
    if not 0 <= start < stop <= n_frames:
        raise ValueError(f"render.frames={value!r}: the range {start}:{stop} is empty or outside this "
                         f"profile's frames 0:{n_frames} (data.segments x data.frames_per_segment)")
    return start, stop
