"""Counts in words that agree with the numbers (``1 command``, ``2 commands``), for the
lines a person reads (the record CLI's summary, the HMI's log)."""

from __future__ import annotations


def counted(n: int, word: str) -> str:
    """``1 sample``, ``2 samples``: a count with its noun."""
    return f"{n} {word}{'' if n == 1 else 's'}"
