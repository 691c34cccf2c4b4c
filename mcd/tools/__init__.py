"""A user's measuring tools: they read the product (``mcd.data``, ``mcd.models``, ``mcd.lit``...) and print or
write figures, and nothing below them imports them (docs/architecture.md, "Layers"). The speed, training,
profile and loader benchmarks are the modes of ``python -m mcd.bench`` (``mcd/bench/``); the lab's
investigation tools are outside the package, in the checkout's ``tools/``.

- ``complexity``: params and MACs of every experiment against the paper's;
- ``edge_effect``: what the image border costs a finished run (the report's ``edge effect`` column);
- ``check_paths``: camera-path frames rendered from inside a wall;
- ``bundle``: a finished run -> a bundled checkpoint of ``mcd-denoise``.
"""
