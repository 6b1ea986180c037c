"""A trace writer for long runs: lines go to the file only (not kept in memory)."""

from __future__ import annotations

from typing import TextIO

from esair_min.core.trace import TraceWriter


class FileTraceWriter(TraceWriter):
    """:class:`TraceWriter` that streams to ``stream`` without keeping every line
    (``keep=False``): ``lines`` holds only the header; an emulator serving a person
    for hours would otherwise hold its whole trace in memory."""

    def __init__(self, stream: TextIO):
        super().__init__(stream, keep=False)
