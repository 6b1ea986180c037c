"""A plain text table of rows (``esair std ls``, ``run``'s summary)."""

from __future__ import annotations

from typing import Mapping, Sequence


def table(rows: Sequence[Mapping[str, object]], cols: list[str]) -> str:
    """``cols`` as upper-case headers over one left-justified line per row."""
    widths = {c: max(len(c), *(len(str(r.get(c, ""))) for r in rows)) if rows else len(c)
              for c in cols}
    out = ["  ".join(c.upper().ljust(widths[c]) for c in cols)]
    for r in rows:
        out.append("  ".join(str(r.get(c, "")).ljust(widths[c]) for c in cols))
    return "\n".join(line.rstrip() for line in out)
