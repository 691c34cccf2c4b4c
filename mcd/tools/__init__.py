"""Measuring tools: they read the product (``mcd.data``, ``mcd.models``, ``mcd.lit``...) and print or write
figures, and nothing in the product imports them (docs/architecture.md, "Layers").

- ``bench``: inference speed (``python -m mcd.bench``, whose ``train`` and ``profile`` modes are
  ``train_bench`` and ``inference_profile``);
- ``complexity``: params and MACs of every experiment against the paper's;
- ``edge_effect``: what the image border costs a finished run;
- ``check_paths``: camera-path frames rendered from inside a wall;
- ``bundle``: a finished run -> a bundled checkpoint of ``mcd-denoise``;
- ``loader_bench``: training clips/s of one loader worker, EXR against the training store
  (``python -m mcd.bench loader``, over ``mcd.data.loader_rate``; docs/training_store.md).
"""
