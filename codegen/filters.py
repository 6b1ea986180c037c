"""The named Jinja2 filters the firmware templates may use (and no others)."""

from __future__ import annotations

from typing import Iterable


def hex2(value: int) -> str:
    """``0x5A``: one byte as a C hex literal."""
    if not 0 <= value <= 0xFF:
        raise ValueError(f"hex2: {value} is not a byte")
    return f"0x{value:02X}"


def hex4(value: int) -> str:
    """``0x042E``: a 16-bit value as a C hex literal."""
    if not 0 <= value <= 0xFFFF:
        raise ValueError(f"hex4: {value} is not a 16-bit value")
    return f"0x{value:04X}"


def c_string(value: bytes | str) -> str:
    """A C string literal with every byte outside printable ASCII (and ``"``, ``\\``,
    ``?``) escaped as octal, so the literal means exactly these bytes."""
    data = value.encode("ascii") if isinstance(value, str) else bytes(value)
    out = []
    for b in data:
        if 0x20 <= b <= 0x7E and b not in (0x22, 0x5C, 0x3F):
            out.append(chr(b))
        else:
            out.append(f"\\{b:03o}")
    return '"' + "".join(out) + '"'


def c_bytes(data: bytes | Iterable[int], per_line: int = 12, indent: str = "    ") -> str:
    """Comma-separated ``0xHH`` bytes, ``per_line`` to a line, for array initialisers."""
    items = [hex2(b) for b in bytes(data)]
    lines = [", ".join(items[i:i + per_line]) for i in range(0, len(items), per_line)]
    return (",\n" + indent).join(lines) if lines else "0x00"


def c_ident(value: str) -> str:
    """An upper-case C identifier fragment (model names are ``[a-z][a-z0-9_]*``)."""
    return value.upper()


FILTERS = {"hex2": hex2, "hex4": hex4, "c_string": c_string, "c_bytes": c_bytes,
           "c_ident": c_ident}
