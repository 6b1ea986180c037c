"""Write a tree of generated files, touching only the files whose content changed."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from esair_min.errors import GenerateError


@dataclass(frozen=True)
class WriteResult:
    written: tuple[Path, ...]
    unchanged: tuple[Path, ...]


def write_if_changed(path: Path, data: bytes) -> bool:
    """Write ``data`` to ``path`` unless it already holds exactly that; True if written."""
    try:
        if path.is_file() and path.read_bytes() == data:
            return False
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + ".tmp")
        tmp.write_bytes(data)
        tmp.replace(path)
    except OSError as exc:
        raise GenerateError(f"cannot write {path}: {exc.strerror}") from None
    return True


def write_tree(files: dict[str, str], out_dir: Path, *, check: bool = True) -> WriteResult:
    """Write ``{relative path: text}`` under ``out_dir`` in sorted order.

    With ``check=False`` every file is written (the baseline of bench/codegen_time.py).
    """
    written: list[Path] = []
    unchanged: list[Path] = []
    for rel in sorted(files):
        path = out_dir / rel
        data = files[rel].encode("utf-8")
        if check:
            (written if write_if_changed(path, data) else unchanged).append(path)
        else:
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_bytes(data)
            except OSError as exc:
                raise GenerateError(f"cannot write {path}: {exc.strerror}") from None
            written.append(path)
    return WriteResult(tuple(written), tuple(unchanged))
