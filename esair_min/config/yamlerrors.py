"""PyYAML's syntax errors in plain words: what is wrong, and how to fix it.

PyYAML reports indentation and structure mistakes in the words of its parser
(``expected <block end>, but found '?'``). :func:`explain` reads the lines around the
mark and says what the file shows instead (``'delay_ticks' is indented 2 spaces, less
than 'number' above it ...``) and how to fix it. The messages speak of YAML only (keys,
blocks, lists, quotes), never of one kind of file: every YAML file ESAIR reads goes
through here. Mistakes no rule recognises keep PyYAML's words.

Positions: an explanation is given at PyYAML's own mark, except where that mark is not
on the mistake: a key without ':', a quote or bracket never closed and a stray '*' or
'&' are reported where they start (PyYAML points at the line after, the end of the
file, or the character after the '*').
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import yaml

_KEY = re.compile(r"""(?:-\s+)*(?P<key>"[^"]*"|'[^']*'|[^\s#:'"\-{\[][^#]*?|-[^\s#:][^#]*?)\s*(?P<colon>:)(?:\s|$)""")  # noqa: E501


@dataclass(frozen=True)
class Explained:
    """A plain-words message and its 0-based (line, column)."""

    message: str
    line: int
    col: int


def _spaces(n: int) -> str:
    return "not indented" if n == 0 else f"indented {n} space{'s' if n != 1 else ''}"


def _indent_to(n: int) -> str:
    return "remove its indentation" if n == 0 else f"indent it by {n} space{'s' if n != 1 else ''}"


class _Text:
    def __init__(self, text: str):
        self.lines = text.splitlines()

    def line(self, i: int) -> str:
        return self.lines[i] if 0 <= i < len(self.lines) else ""

    def content(self, i: int) -> bool:
        s = self.line(i).strip()
        return bool(s) and not s.startswith("#")

    def prev(self, i: int) -> int | None:
        """The nearest line above ``i`` with content (not blank, not a comment)."""
        for j in range(i - 1, -1, -1):
            if self.content(j):
                return j
        return None

    def first(self) -> int | None:
        return next((j for j in range(len(self.lines)) if self.content(j)), None)

    def key(self, i: int, col: int | None = None) -> tuple[str, int, int] | None:
        """The key written on line ``i`` (from ``col``, after any '- '): (key, its
        column, the column of its ':')."""
        text = self.line(i)
        start = len(text) - len(text.lstrip(" ")) if col is None else col
        m = _KEY.match(text, start)
        if not m:
            return None
        key = m.group("key")
        if key[:1] in "'\"":
            key = key[1:-1]
        return key, m.start("key"), m.start("colon")

    def dash(self, i: int) -> int | None:
        """The column of the '-' that starts line ``i``, if it is a list item."""
        text = self.line(i)
        s = text.lstrip(" ")
        if s == "-" or s.startswith("- "):
            return len(text) - len(s)
        return None

    def indent(self, i: int) -> int:
        text = self.line(i)
        return len(text) - len(text.lstrip(" "))

    def level_above(self, i: int, p: int) -> tuple[str, int, int] | None:
        """The key of the nearest block open above line ``i`` whose keys stand right of
        column ``p`` (the innermost such): (key, its column, its line)."""
        best = None
        floor = 1 << 30
        for j in range(i - 1, -1, -1):
            if not self.content(j) or self.indent(j) >= floor:
                continue
            floor = self.indent(j)
            k = self.key(j)
            if k is not None and k[1] > p and (best is None or k[1] < best[1]):
                best = (k[0], k[1], j)
            if floor <= p:
                break
        return best

    def key_at_column(self, i: int, col: int) -> tuple[str, int, int] | None:
        """The nearest key above line ``i`` written at column ``col``: (key, col, line)."""
        for j in range(i - 1, -1, -1):
            if not self.content(j):
                continue
            k = self.key(j)
            if k is not None and k[1] == col:
                return k[0], k[1], j
            if self.indent(j) < col:
                return None
        return None

    def owner(self, i: int, col: int) -> tuple[str, int, int] | None:
        """The key that holds the block starting at line ``i`` column ``col``: (key, its
        column, its line), the nearest key above standing left of (or at) ``col``."""
        for j in range(i - 1, -1, -1):
            if not self.content(j):
                continue
            k = self.key(j)
            if (k is not None and k[1] <= col and self.dash(j) != col
                    and (k[1] < col or self.line(j).rstrip().endswith(":"))):
                return k[0], k[1], j
            if self.indent(j) < col:
                return None
        return None


def explain(exc: yaml.MarkedYAMLError, text: str) -> Explained | None:
    """A plain-words message for PyYAML's ``exc`` on ``text``, or None."""
    pm, cm = exc.problem_mark, exc.context_mark
    problem, context = exc.problem or "", exc.context or ""
    if pm is None:
        return None
    t = _Text(text)
    for rule in _RULES:
        got = rule(t, problem, context, pm, cm)
        if got is not None:
            return got
    return None


# -- the rules: each returns an Explained or None -------------------------------------

def _less_indented_key(t: _Text, problem, context, pm, cm) -> Explained | None:
    """A key indented less than its siblings above (PyYAML: expected <block end>, but
    found '<block mapping start>' or '?')."""
    if problem not in ("expected <block end>, but found '<block mapping start>'",
                       "expected <block end>, but found '?'") or cm is None:
        return None
    found = t.key(pm.line, pm.column)
    if found is None:
        return None
    key, p = found[0], pm.column
    level = t.level_above(pm.line, p)
    if context != "while parsing a block mapping" and p == cm.column:
        head = (f"'{key}' stands at the column of the list's '-' items (line "
                f"{cm.line + 1}); a block holds either keys or '-' items, not both")
    elif level is not None:
        head = (f"'{key}' is {_spaces(p)}, less than '{level[0]}' above it (line "
                f"{level[2] + 1})")
    else:
        head = f"'{key}' is {_spaces(p)}, which matches no key above it"
    advice = []
    if level is not None:
        named = head.find(f"'{level[0]}'") > 0
        advice.append(f"{_indent_to(level[1])} like '{level[0]}'"
                      + ("" if named else f" (line {level[2] + 1})"))
    if context == "while parsing a block mapping":
        outer = t.key_at_column(pm.line, cm.column)
    else:                                          # a block sequence
        outer = t.owner(cm.line, cm.column)
    if outer is not None and outer[1] < p:
        advice.append(f"{'or ' if advice else ''}{_indent_to(outer[1])} to place it "
                      f"beside '{outer[0]}' (line {outer[2] + 1})")
    if not advice:
        advice.append("indent it like the keys it belongs with")
    return Explained(f"{head}; {', '.join(advice)}", pm.line, pm.column)


def _dash_among_keys(t: _Text, problem, context, pm, cm) -> Explained | None:
    """A '-' list item where keys are (expected <block end>, but found '-')."""
    if problem != "expected <block end>, but found '-'" or cm is None:
        return None
    holder = t.key(cm.line, cm.column)
    beside = f" ('{holder[0]}', line {cm.line + 1})" if holder else ""
    return Explained(
        f"a '-' list item among the keys of a block{beside}: a block holds either keys or "
        "'-' items, not both; remove the '-' if this line is one more key, or put the "
        "items under a key of their own ('key:', the items indented below it)",
        pm.line, pm.column)


def _misaligned_item(t: _Text, problem, context, pm, cm) -> Explained | None:
    """A '-' item indented unlike the items before it."""
    if problem != "expected <block end>, but found '<block sequence start>'":
        return None
    for j in range(pm.line - 1, -1, -1):
        d = t.dash(j)
        if d is not None and d != pm.column:
            return Explained(
                f"this '-' item is {_spaces(pm.column)}, but the item above it (line "
                f"{j + 1}) is {_spaces(d)}; indent every item of a list alike",
                pm.line, pm.column)
    return None


def _text_after_quote(t: _Text, problem, context, pm, cm) -> Explained | None:
    if problem != "expected <block end>, but found '<scalar>'":
        return None
    before = t.line(pm.line)[:pm.column].rstrip()
    if not before.endswith(("'", '"')):
        return None
    return Explained("text after the closing quote of a quoted value; put all of the "
                     "value inside the quotes", pm.line, pm.column)


def _mapping_value_here(t: _Text, problem, context, pm, cm) -> Explained | None:
    """``mapping values are not allowed here``: a key indented under a key that already
    has a value, or ': ' inside a plain value."""
    if problem != "mapping values are not allowed here":
        return None
    line = t.line(pm.line)
    own = t.key(pm.line)
    if own is not None and own[2] == pm.column:
        key, p = own[0], own[1]
        prev = t.prev(pm.line)
        pk = t.key(prev) if prev is not None else None
        if prev is not None and pk is None and t.dash(prev) is None and t.indent(prev) <= p:
            text = t.line(prev).strip()
            return Explained(f"'{text}' has no ':', so YAML reads it and the next line as "
                             "one text; write a key and its value as 'key: value' (a colon "
                             "and a space after the key)", prev, t.indent(prev))
        if pk is not None and pk[1] < p:
            return Explained(
                f"'{key}' is {_spaces(p)}, more than '{pk[0]}' above it ({pk[1]} spaces, "
                f"line {prev + 1}), which already has a value; {_indent_to(pk[1])} like "  # type: ignore[operator]
                f"'{pk[0]}'", pm.line, pm.column)
        return Explained(f"'{key}' is {_spaces(p)}, more than the line above it, which "
                         "already has a value; indent it like the keys it belongs with",
                         pm.line, pm.column)
    holder = t.key(pm.line)
    if holder is None:
        return None
    value = line[holder[2] + 1:].split(" #")[0].strip()
    quoted = f'{holder[0]}: "{value}"' if '"' not in value else f"{holder[0]}: '{value}'"
    return Explained(f"': ' inside the value of '{holder[0]}' would start a second key on "
                     f"one line; put the value in quotes ({quoted})", pm.line, pm.column)


def _dash_after_key(t: _Text, problem, context, pm, cm) -> Explained | None:
    if problem != "sequence entries are not allowed here":
        return None
    holder = t.key(pm.line)
    if holder is not None and holder[1] < pm.column:
        return Explained(f"a '-' list item cannot follow '{holder[0]}:' on the same line; "
                         f"start the list on the next line, indented below '{holder[0]}'",
                         pm.line, pm.column)
    return Explained("a '-' list item cannot start here; a list starts on its own line, "
                     "below the key that holds it", pm.line, pm.column)


def _no_colon(t: _Text, problem, context, pm, cm) -> Explained | None:
    if problem != "could not find expected ':'" or cm is None:
        return None
    text = t.line(cm.line).strip()
    if len(text) > 40:
        text = text[:37] + "..."
    return Explained(f"'{text}' has no ':'; write a key and its value as 'key: value' "
                     "(a colon and a space after the key), or make it a comment with '#'",
                     cm.line, cm.column)


def _unclosed_quote(t: _Text, problem, context, pm, cm) -> Explained | None:
    if context not in ("while scanning a quoted scalar",
                       "while scanning a double-quoted scalar") or cm is None:
        return None
    q = t.line(cm.line)[cm.column:cm.column + 1] or '"'
    if problem.startswith("found unexpected end of stream") or \
            problem.startswith("found unexpected document separator"):
        return Explained(f"the {q} opened here is never closed; add the closing {q} at the "
                         "end of the value", cm.line, cm.column)
    m = re.match(r"found unknown escape character '(.*)'", problem)
    if m:
        return Explained(f"'\\{m.group(1)}' is not an escape YAML knows between double "
                         "quotes; use single quotes for text with backslashes, or write "
                         "'\\\\' for one backslash", pm.line, pm.column)
    return None


_FLOW = re.compile(r"expected ',' or '([}\]])', but got '(.*)'")


def _flow(t: _Text, problem, context, pm, cm) -> Explained | None:
    m = _FLOW.match(problem)
    if not m or cm is None:
        return None
    close, got = m.groups()
    opener = "{" if close == "}" else "["
    what = "mapping" if close == "}" else "list"
    if got == "<stream end>" or pm.line > cm.line:
        return Explained(f"this '{opener}' starts a {what} that is not closed before "
                         f"{'the end of the file' if got == '<stream end>' else f'line {pm.line + 1}'}"
                         f"; end it with '{close}'", cm.line, cm.column)
    if got == ":":
        return Explained(f"a ':' inside {opener}...{close} where ',' or '{close}' should "
                         "come; separate the entries with ', ', or quote a value that holds "
                         "': '", pm.line, pm.column)
    return None


def _alias_anchor(t: _Text, problem, context, pm, cm) -> Explained | None:
    if context not in ("while scanning an alias", "while scanning an anchor") or cm is None:
        return None
    ch = "*" if context.endswith("alias") else "&"
    role = "an alias (a reference to an '&' anchor)" if ch == "*" else "an anchor name"
    return Explained(f"'{ch}' starts {role}; to write text that starts with '{ch}', put "
                     "it in quotes", cm.line, cm.column)


def _bad_start(t: _Text, problem, context, pm, cm) -> Explained | None:
    m = re.match(r"found character '(.*)' that cannot start any token", problem)
    if not m:
        return None
    ch = m.group(1)
    if ch == "\\t":
        return Explained("a tab character: YAML indents with spaces only; replace the tab "
                         "by spaces", pm.line, pm.column)
    return Explained(f"'{ch}' cannot start a value in YAML (it is reserved); put the value "
                     "in quotes", pm.line, pm.column)


def _top_level(t: _Text, problem, context, pm, cm) -> Explained | None:
    if not problem.startswith("expected '<document start>', but found"):
        return None
    first = t.first()
    found = t.key(pm.line, pm.column)
    if first is None or found is None or t.indent(first) == pm.column:
        return None
    fk = t.key(first)
    name = f"'{fk[0]}', " if fk else ""
    return Explained(
        f"'{found[0]}' is {_spaces(pm.column)}, but the first key of the file ({name}line "
        f"{first + 1}) is {_spaces(t.indent(first))}; indent every top-level key alike "
        "(usually not at all)", pm.line, pm.column)


def _second_document(t: _Text, problem, context, pm, cm) -> Explained | None:
    if problem != "but found another document":
        return None
    return Explained("a second YAML document starts here ('---'), but one document is "
                     "expected; remove this line and what follows it, or merge the two",
                     pm.line, pm.column)


_RULES = (_less_indented_key, _dash_among_keys, _misaligned_item, _text_after_quote,
          _mapping_value_here, _dash_after_key, _no_colon, _unclosed_quote, _flow,
          _alias_anchor, _bad_start, _top_level, _second_document)
