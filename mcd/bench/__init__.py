"""``python -m mcd.bench``: the benchmark command; its modes are the tools in :mod:`mcd.tools`
(``mcd/bench/__main__.py``)."""
