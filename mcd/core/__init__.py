"""Plumbing of ``mcd``: small modules with one job each that every layer above may use and that import
nothing else of ``mcd`` (docs/architecture.md, "Layers")."""
