"""Text from run records made safe for a report's Markdown (docs/benchmark.md "Reports").

Strings that come from data (``metrics.json``, ``error.json``, a run's config, a sweep's command) reach a
report's README.md, its tables and ``reports/README.md``. :func:`escape` makes each such string plain text:
``<`` becomes ``&lt;`` (no HTML tag, e.g. ``<script>`` or ``<img onerror>``, can start; ``>`` alone opens
none, so the findings' ``F >= ...`` reads as written), ``|`` is escaped (no table cell is split) and line
breaks become spaces (no line of Markdown is started). It is idempotent, so text read back from a report
(the reports index) can pass through it again.
"""

from __future__ import annotations

import re

_PIPE = re.compile(r"(?<!\\)\|")


def escape(value: object) -> str:
    """``value`` as plain Markdown text (module docstring)."""
    text = str(value).replace("<", "&lt;")
    return _PIPE.sub(r"\\|", " ".join(text.splitlines()))
