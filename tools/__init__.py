"""The lab: investigation tools that read the product (``mcd``) and print or write figures; not packaged,
not installed (tools/README.md). Nothing in ``mcd`` imports them (tests/test_layers.py)."""
