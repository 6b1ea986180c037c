"""Read one YAML file into plain data plus the marks of every node.

PyYAML composes the node graph (which keeps line/column marks); this module turns it
into dicts, lists and scalars while recording, for every path such as
``("servos", 3, "max_angle")``, where its value (and its key) stand in the file.
It refuses what PyYAML would silently accept: duplicate keys, alias expansion that
grows without bound (or refers to itself), and non-string keys. Every error is one
:class:`ConfigError` on one line with the mark of the node to change.

The graph is composed by libyaml where PyYAML has it (the same parser in C, about ten
times faster: a start that checks its board files pays for this), unless the text is
one where the two differ (a tab, which libyaml takes where PyYAML refuses it; an empty
value, whose mark libyaml puts a column further; more brackets than PyYAML's flow
guard allows); any error there is read again by PyYAML's Python parser, whose
messages (and marks) are the ones given.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from esair_min.config.words import kind_of
from esair_min.config.yamlerrors import explain
from esair_min.errors import ConfigError, Mark, file_mark, path_mark

Path_ = tuple[Any, ...]

#: Most nodes a single board file may expand to (aliases included). A PAPA-MAN board
#: is a few hundred; this stops "billion laughs" documents long before memory does.
MAX_NODES = 100_000
#: Largest board file read, in bytes.
MAX_FILE_BYTES = 1_000_000
#: Deepest nesting of mappings and lists (a PAPA-MAN board needs 5).
MAX_DEPTH = 32
#: Deepest ``[``/``{`` nesting the reader follows before it gives up: PyYAML's scanner
#: takes time quadratic in it (thousands of brackets took seconds), and anything past
#: MAX_DEPTH is refused anyway.
MAX_FLOW_LEVEL = 4 * MAX_DEPTH


class _TooDeep(Exception):
    pass


class _Loader(yaml.SafeLoader):
    """SafeLoader that stops at MAX_FLOW_LEVEL nested flow collections."""

    def fetch_flow_collection_start(self, TokenClass):  # the argument keeps PyYAML's name
        if self.flow_level >= MAX_FLOW_LEVEL:
            raise _TooDeep
        super().fetch_flow_collection_start(TokenClass)


def _compose_fast(text: str) -> tuple[yaml.Node | None, Any] | None:
    """(the node, a loader to construct its scalars) composed by libyaml; None when
    libyaml is missing, or the text is one for PyYAML's parser (the module docstring)."""
    fast = getattr(yaml, "CSafeLoader", None)
    if (fast is None or "\t" in text
            or text.count("[") + text.count("{") >= MAX_FLOW_LEVEL):
        return None
    loader = fast(text)
    try:
        node = loader.get_single_node()
    except (yaml.YAMLError, RecursionError):
        return None
    finally:
        loader.dispose()
    todo = [node] if node is not None else []
    seen: set[int] = set()
    while todo:
        n = todo.pop()
        if id(n) in seen:
            continue
        seen.add(id(n))
        if isinstance(n, yaml.ScalarNode):
            if n.value == "" and not n.style:       # plain empty (a quoted one is fine)
                return None
        elif isinstance(n, yaml.MappingNode):
            todo += [x for kv in n.value for x in kv]
        elif isinstance(n, yaml.SequenceNode):
            todo += n.value
    return node, loader


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


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


@dataclass(frozen=True)
class FileKind:
    """How messages name the file being read: board files and STD deployment files."""

    name: str = "board file"
    description: str = "a board description"
    keys: str = "board:, role:, i2c:, ..."


BOARD_FILE = FileKind()


def _mark(path: str, node: yaml.Node) -> Mark:
    m = node.start_mark
    return Mark(path, m.line + 1, m.column + 1)


_PLAIN_TAGS = ("tag:yaml.org,2002:map", "tag:yaml.org,2002:seq")


class _Builder:
    def __init__(self, path: str, loader: Any, kind: FileKind = BOARD_FILE):
        self.path = path
        self.kind = kind
        self.loader = loader
        self.nodes = 0
        self.open: set[int] = set()   # ids of the collections being built (cycle check)
        self.value_marks: dict[Path_, Mark] = {}
        self.key_marks: dict[Path_, Mark] = {}

    def build(self, node: yaml.Node, loc: Path_) -> Any:
        self.nodes += 1
        if self.nodes > MAX_NODES:
            # Point at the top-level key whose value explodes, not deep inside it.
            where = self.value_marks.get(loc[:1]) if loc else None
            raise ConfigError(
                f"aliases expand this document to more than {MAX_NODES} values "
                "(a billion-laughs style alias bomb?); write the values out instead "
                "of nesting '*' aliases",
                where or _mark(self.path, node),
            )
        self.value_marks[loc] = _mark(self.path, node)
        if isinstance(node, yaml.ScalarNode):
            return self._scalar(node)
        if id(node) in self.open:
            raise ConfigError("this list or mapping contains a '*' alias of itself "
                              "(endless recursion); remove that alias",
                              _mark(self.path, node))
        if len(loc) >= MAX_DEPTH:
            raise ConfigError(f"nested more than {MAX_DEPTH} levels deep; a {self.kind.name} "
                              "needs far fewer", _mark(self.path, node))
        if node.tag not in _PLAIN_TAGS:
            raise ConfigError(f"cannot read value: unsupported tag '{node.tag}' (remove the "
                              "'!' tag)", _mark(self.path, node))
        self.open.add(id(node))
        try:
            if isinstance(node, yaml.MappingNode):
                return self._mapping(node, loc)
            return [self.build(item, loc + (i,)) for i, item in enumerate(node.value)]
        finally:
            self.open.discard(id(node))

    def _scalar(self, node: yaml.ScalarNode) -> Any:
        try:
            return self.loader.construct_object(node, deep=True)
        except (yaml.YAMLError, ValueError, TypeError, OverflowError) as exc:
            # ValueError & co.: a tagged or date-like scalar PyYAML cannot convert.
            problem = getattr(exc, "problem", None) or str(exc)
            if "integer string conversion" in problem:
                raise ConfigError(f"a number of {len(node.value)} characters is too long to "
                                  "read (at most 4300 digits); quote it to keep it as text",
                                  _mark(self.path, node)) from None
            raise ConfigError(f"cannot read value: {_one_line(problem)} "
                              "(quote the value, or remove its '!' tag)",
                              _mark(self.path, node)) from None

    def _mapping(self, node: yaml.MappingNode, loc: Path_) -> dict[str, Any]:
        # Merge keys (<<) would need PyYAML's flattening; board files do not need them.
        out: dict[str, Any] = {}
        for key_node, value_node in node.value:
            if not isinstance(key_node, yaml.ScalarNode) or key_node.tag == "tag:yaml.org,2002:merge":
                raise ConfigError(
                    "keys must be plain names (no merge keys, lists or mappings as keys)",
                    _mark(self.path, key_node),
                )
            key = self._scalar(key_node)
            if not isinstance(key, str):
                raise ConfigError(f"key {_one_line(key_node.value)!r} must be a name, not "
                                  f"{kind_of(key)}", _mark(self.path, key_node))
            if key in out:
                first = self.key_marks[loc + (key,)]
                raise ConfigError(
                    f"duplicate key {key!r} (first given at line {first.line}); "
                    "keep only one of them",
                    _mark(self.path, key_node),
                )
            self.key_marks[loc + (key,)] = _mark(self.path, key_node)
            out[key] = self.build(value_node, loc + (key,))
        return out


def load_yaml(path: Path | str, kind: FileKind = BOARD_FILE) -> Document:
    """Load ``path``; raise :class:`ConfigError` with a mark for anything unreadable.

    ``kind`` names the file in messages (a board file unless told otherwise).
    """
    what_file = kind.name
    p = Path(path)
    name = str(path)
    if not p.exists():
        raise ConfigError("no such file or folder", path_mark(name))
    if p.is_dir():
        raise ConfigError(f"is a folder, but a {what_file} (YAML) was expected here; "
                          "rename or move it", file_mark(name))
    if not p.is_file():
        raise ConfigError("is not a regular file (a device or pipe?); a "
                          f"{what_file} is expected here", file_mark(name))
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise ConfigError(f"cannot read the file: {exc.strerror or exc}",
                          file_mark(name)) from None
    if len(raw) > MAX_FILE_BYTES:
        raise ConfigError(f"file is {len(raw)} bytes, larger than the {MAX_FILE_BYTES} "
                          f"bytes a {what_file} may have", file_mark(name))
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"not a text file (invalid UTF-8 at byte {exc.start}); a "
                          f"{what_file} is UTF-8 YAML", file_mark(name)) from None
    fast = _compose_fast(text)
    if fast is not None:
        node, loader = fast
    else:
        node, loader = _compose(text, name, what_file)
    if node is None or (isinstance(node, yaml.ScalarNode) and node.tag.endswith(":null")):
        raise ConfigError(f"file is empty, expected {kind.description} ({kind.keys})",
                          file_mark(name))
    if not isinstance(node, yaml.MappingNode):
        what = "a list" if isinstance(node, yaml.SequenceNode) else "a single value"
        raise ConfigError(f"the file is {what}; a {what_file} must be a mapping of keys "
                          f"({kind.keys})", _mark(name, node))
    builder = _Builder(name, loader, kind)
    data = builder.build(node, ())
    return Document(name, data, builder.value_marks, builder.key_marks)


def _compose(text: str, name: str, what_file: str) -> tuple[yaml.Node | None, _Loader]:
    """PyYAML's Python parser: the node, or a :class:`ConfigError` in plain words."""
    try:
        loader = _Loader(text)
    except yaml.reader.ReaderError as exc:
        raise _reader_error(exc, text, name) from None
    try:
        node = loader.get_single_node()
    except yaml.reader.ReaderError as exc:
        raise _reader_error(exc, text, name) from None
    except yaml.MarkedYAMLError as exc:
        plain = explain(exc, text)
        if plain is not None:
            raise ConfigError(plain.message, Mark(name, plain.line + 1, plain.col + 1)) from None
        m = exc.problem_mark or exc.context_mark
        mark = Mark(name, m.line + 1, m.column + 1) if m else file_mark(name)
        problem = exc.problem or exc.context or "invalid YAML"
        if problem.startswith("but ") and exc.context:
            problem = f"{exc.context}, {problem}"
        raise ConfigError(f"YAML syntax error: {_one_line(problem)}", mark) from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"YAML error: {_one_line(str(exc))}", file_mark(name)) from None
    except (RecursionError, _TooDeep):
        raise ConfigError(f"nested too deeply to read (more than {MAX_DEPTH} levels are "
                          f"never needed in a {what_file})", file_mark(name)) from None
    finally:
        loader.dispose()
    return node, loader


def _reader_error(exc: yaml.reader.ReaderError, text: str, name: str) -> ConfigError:
    """A control character in the text: most likely a binary file."""
    pos = max(0, min(exc.position, len(text)))
    line = text.count("\n", 0, pos) + 1
    col = pos - (text.rfind("\n", 0, pos) + 1) + 1
    return ConfigError(f"control character U+{exc.character:04X} is not allowed in a YAML "
                       "file (is this a binary file?)", Mark(name, line, col))
