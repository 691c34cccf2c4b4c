"""CPU fast paths: the same functions as the paper's blocks, computed faster on the CPU in inference (or, for
grouped convolutions, in training), each with an equivalence test in ``tests/models/test_inference_paths.py``
(docs/inference.md). The blocks themselves (:mod:`mcd.models.ghost_conv`, :mod:`mcd.models.blocks`) read
as the paper describes them and call these where they apply."""
