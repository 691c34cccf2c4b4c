"""Denoise your own frames and scenes with a trained checkpoint (docs/denoise.md).

- :mod:`mcd.denoise.cli`: the command ``mcd-denoise`` / ``python -m mcd.denoise``;
- :mod:`mcd.denoise.frames`, :mod:`mcd.denoise.sequence`: input (a), EXR frames on disk;
- :mod:`mcd.denoise.scene`: input (b), a Mitsuba scene rendered with the real adaptive loop;
- :mod:`mcd.denoise.weights`: what ``--checkpoint`` names (run dir, ``.ckpt``, bundled name);
- :mod:`mcd.denoise.tiles`: tiles under ``--max-memory-mb``; :mod:`mcd.denoise.output`: what is written;
- :mod:`mcd.bundle`: a finished run directory -> a bundled checkpoint (``mcd/bundled/``);
- :mod:`mcd.denoise.render_frames`: a noisy EXR sequence of a Mitsuba scene in the format of input (a).
"""
