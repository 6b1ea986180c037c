"""Read one YAML file into plain data plus the marks of every node.

PyYAML composes the node graph (which keeps line/column marks); this module turns it
into dicts, lists and scalars while recording, for every path such as
``("servos", 3, "max_angle")``, where its value (and its key) stand in the file.
It refuses what PyYAML would silently accept: duplicate keys, alias expansion that
grows without bound, and non-string keys.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from .errors import ConfigError, Mark, file_mark

Path_ = tuple[Any, ...]

#: Most nodes a single board file may expand to (aliases included). A PAPA-MAN board
#: is a few hundred; this stops "billion laughs" documents long before memory does.
MAX_NODES = 100_000
#: Largest board file read, in bytes.
MAX_FILE_BYTES = 1_000_000


@dataclass(frozen=True)
class Document:
    """A loaded YAML file: its data and where each part of it was written."""

    path: str
    data: Any
    value_marks: dict[Path_, Mark] = field(default_factory=dict)
    key_marks: dict[Path_, Mark] = field(default_factory=dict)

    def mark(self, loc: Path_, *, key: bool = False) -> Mark:
        """The mark of ``loc``, or of its nearest ancestor that has one."""
        loc = tuple(loc)
        while True:
            if key and loc in self.key_marks:
                return self.key_marks[loc]
            if loc in self.value_marks:
                return self.value_marks[loc]
            if not loc:
                return file_mark(self.path)
            loc = loc[:-1]


def _mark(path: str, node: yaml.Node) -> Mark:
    m = node.start_mark
    return Mark(path, m.line + 1, m.column + 1)


class _Builder:
    def __init__(self, path: str, loader: yaml.SafeLoader):
        self.path = path
        self.loader = loader
        self.nodes = 0
        self.value_marks: dict[Path_, Mark] = {}
        self.key_marks: dict[Path_, Mark] = {}

    def build(self, node: yaml.Node, loc: Path_) -> Any:
        self.nodes += 1
        if self.nodes > MAX_NODES:
            raise ConfigError(
                f"document expands to more than {MAX_NODES} nodes "
                "(recursive or exploding aliases?)",
                _mark(self.path, node),
            )
        self.value_marks[loc] = _mark(self.path, node)
        if isinstance(node, yaml.MappingNode):
            return self._mapping(node, loc)
        if isinstance(node, yaml.SequenceNode):
            return [self.build(item, loc + (i,)) for i, item in enumerate(node.value)]
        try:
            return self.loader.construct_object(node, deep=True)
        except yaml.YAMLError as exc:
            raise ConfigError(f"cannot read value: {exc}", _mark(self.path, node)) from None

    def _mapping(self, node: yaml.MappingNode, loc: Path_) -> dict[str, Any]:
        # Merge keys (<<) would need PyYAML's flattening; board files do not need them.
        out: dict[str, Any] = {}
        for key_node, value_node in node.value:
            if not isinstance(key_node, yaml.ScalarNode) or key_node.tag == "tag:yaml.org,2002:merge":
                raise ConfigError(
                    "keys must be plain names (no merge keys, lists or mappings as keys)",
                    _mark(self.path, key_node),
                )
            key = self.loader.construct_object(key_node)
            if not isinstance(key, str):
                raise ConfigError(f"key {key!r} must be a name, not a {type(key).__name__}",
                                  _mark(self.path, key_node))
            if key in out:
                first = self.key_marks[loc + (key,)]
                raise ConfigError(
                    f"duplicate key '{key}' (first given at line {first.line})",
                    _mark(self.path, key_node),
                )
            self.key_marks[loc + (key,)] = _mark(self.path, key_node)
            out[key] = self.build(value_node, loc + (key,))
        return out


def load_yaml(path: Path | str) -> Document:
    """Load ``path``; raise :class:`ConfigError` with a mark for anything unreadable."""
    p = Path(path)
    name = str(path)
    if not p.exists():
        raise ConfigError("no such file", file_mark(name))
    if p.is_dir():
        raise ConfigError("is a directory, expected a YAML board file", file_mark(name))
    raw = p.read_bytes()
    if len(raw) > MAX_FILE_BYTES:
        raise ConfigError(f"file is {len(raw)} bytes, larger than the {MAX_FILE_BYTES} "
                          "bytes a board file may have", file_mark(name))
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"not a text file (invalid UTF-8 at byte {exc.start})",
                          file_mark(name)) from None
    loader = yaml.SafeLoader(text)
    try:
        node = loader.get_single_node()
    except yaml.MarkedYAMLError as exc:
        m = exc.problem_mark or exc.context_mark
        mark = Mark(name, m.line + 1, m.column + 1) if m else file_mark(name)
        problem = exc.problem or exc.context or "invalid YAML"
        raise ConfigError(f"YAML syntax error: {problem}", mark) from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"YAML error: {exc}", file_mark(name)) from None
    finally:
        loader.dispose()
    if node is None:
        raise ConfigError("file is empty, expected a board description", file_mark(name))
    if not isinstance(node, yaml.MappingNode):
        raise ConfigError("top level must be a mapping of keys (board:, mcu:, ...)",
                          _mark(name, node))
    builder = _Builder(name, loader)
    data = builder.build(node, ())
    return Document(name, data, builder.value_marks, builder.key_marks)
