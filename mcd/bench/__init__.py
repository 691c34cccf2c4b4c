"""``python -m mcd.bench``: the benchmark command (``mcd/bench/__main__.py``) and its modes, one module each:
``speed`` (inference ms/frame), ``train`` (training steps/s), ``profile`` (time per stage of a two-stage row)
and ``loader`` (clips/s of one training-loader worker)."""
