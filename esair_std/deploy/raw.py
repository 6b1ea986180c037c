"""Checks on the raw data of a deployment, before the model sees it.

What pydantic cannot word well is checked here, on whatever shape the data has
(wrong types are left to the model, which words those): the top-level keys, the
names of components (also across sections), misspelt keys of an entry (every other
key is an option), the ``module:Class`` form, the endpoint, the names in ``uses``,
``allow`` and a reaction's ``resources``. The result is the data the model is built
from: each entry's options gathered under ``options``.
"""

from __future__ import annotations

import difflib
import re
from esair_min.errors import Mark
from esair_min.config.words import did_you_mean, quote, show
from esair_min.config.yamlload import Document, kind_of

from ..endpoint import endpoint_fault
from ..errors import DeployError
from .marks import Loc, PathMark
from .model import (CHILD_PATTERN, CLASS_PATTERN, KIND, NAME_PATTERN,
                    REF_PATTERN, SECTIONS, BehaviorSpec, ReactionSpec, ResourceSpec,
                    top_keys)
from .model import ComponentSpec

SPECS: dict[str, type[ComponentSpec]] = {"resources": ResourceSpec,
                                           "behaviors": BehaviorSpec, "reactions": ReactionSpec}
NAME_TEXT = "a lower-case name (a-z, 0-9, _; at most 32 characters, starting with a letter)"
#: Brackets of a pattern in pairs, each holding at least one character: ``arm[12]``.
_BRACKETS = re.compile(r"^([^\[\]]|\[!?[^\[\]]+\])*$")
#: An unknown key this close to a known one is taken for a typo, not an option.
TYPO_CUTOFF = 0.8


def at(mark: Mark) -> str:
    """``line 7`` in a file, the value's path in a dict."""
    return str(mark) if isinstance(mark, PathMark) else f"line {mark.line}"


def check_raw(doc: Document) -> dict[str, object]:
    """Check ``doc.data``; return it with each entry's options under ``options``."""
    data = doc.data
    if not isinstance(data, dict):
        raise DeployError(f"a deployment must be a mapping of keys (robot:, resources:, "
                          f"behaviors:, ...), not {kind_of(data)}", doc.mark(()))
    keys = top_keys()
    for key in data:
        if key not in keys:
            hint = did_you_mean(key, keys) or f" (allowed here: {', '.join(keys)})"
            raise DeployError(f"unknown key {quote(key)}{hint}", doc.mark((key,), key=True))
    robot = data.get("robot")
    if isinstance(robot, str) and not re.match(NAME_PATTERN, robot):
        raise DeployError(f"'robot' must be {NAME_TEXT}, not {show(robot)}",
                          doc.mark(("robot",)))
    if isinstance(data.get("endpoint"), str):
        check_endpoint(data["endpoint"], doc)
    out: dict[str, object] = dict(data)
    seen: dict[str, tuple[str, Mark]] = {}
    for section in SECTIONS:
        entries = data.get(section)
        if entries is None and section in data:
            out[section] = {}            # an empty section (all entries commented out)
        if not isinstance(entries, dict):
            continue
        out[section] = {name: _entry(doc, section, name, entry, seen)
                        for name, entry in entries.items()}
    return out


def _entry(doc: Document, section: str, name: str, entry: object,
           seen: dict[str, tuple[str, Mark]]) -> object:
    """Check one entry's name and values; its own keys plus ``options``."""
    loc = (section, name)
    _check_name(doc, section, name, seen)
    if not isinstance(entry, dict):
        return entry                     # the model words a wrong type
    out = _split_options(doc, section, entry, loc)
    _check_class(doc, entry, loc)
    if "period" in SPECS[section].KEYS:
        _check_seconds(doc, entry.get("period"), loc + ("period",))
    restart = entry.get("restart") if "restart" in SPECS[section].KEYS else None
    if isinstance(restart, dict):
        _check_seconds(doc, restart.get("within"), loc + ("restart", "within"))
    _check_refs(doc, section, entry, loc)
    options = out.get("options")
    if section == "resources" and isinstance(options, dict) and "rate_hz" in options:
        written = ("rate_hz",) if "rate_hz" in entry else ("options", "rate_hz")
        _check_rate(doc, options["rate_hz"], loc + written)
    return out


def _check_name(doc: Document, section: str, name: str,
                seen: dict[str, tuple[str, Mark]]) -> None:
    kind = KIND[section]
    mark = doc.mark((section, name), key=True)
    if not re.match(NAME_PATTERN, name):
        raise DeployError(f"{kind} name {quote(name)} must be {NAME_TEXT}", mark)
    if name in seen:
        other, first = seen[name]
        raise DeployError(f"name {quote(name)} is already used by {other} ({at(first)}); "
                          "resources, behaviors and reactions need distinct names", mark)
    seen[name] = (f"a {kind}", mark)


def _split_options(doc: Document, section: str, entry: dict[str, object],
                   loc: Loc) -> dict[str, object]:
    """The entry's own keys, and every other key (and those under ``options:``)
    gathered under ``options``."""
    own = SPECS[section].KEYS
    out = {k: v for k, v in entry.items() if k in own}
    options: dict[str, object] = {}
    for key, value in entry.items():
        if key not in own:
            _not_a_typo(doc, section, loc + (key,), key)
            options[key] = value
    given = entry.get("options")
    if isinstance(given, dict):
        for key in given:
            if key in options:
                raise DeployError(f"option {quote(key)} is given both as a key of the entry "
                                  "and under 'options:'; keep one",
                                  doc.mark(loc + ("options", key), key=True))
        options.update(given)
    elif given is not None:
        return out                       # 'options' of a wrong type: the model words it
    if options or "options" in entry:
        out["options"] = options
    return out


def _not_a_typo(doc: Document, section: str, loc: Loc, key: str) -> None:
    """An unknown key becomes an option, unless it looks like a misspelt key."""
    own = SPECS[section].KEYS
    close = difflib.get_close_matches(key, own, n=1, cutoff=TYPO_CUTOFF)
    if close:
        raise DeployError(f"unknown key {quote(key)} (did you mean '{close[0]}'?); to pass "
                          "it to the component as an option, put it under 'options:'",
                          doc.mark(loc, key=True))
    for other in SECTIONS:
        if other != section and key in SPECS[other].KEYS:
            raise DeployError(f"{quote(key)} is a key of {other}, not of a {KIND[section]}; "
                              "to pass it to the component as an option, put it under "
                              "'options:'", doc.mark(loc, key=True))


def _check_class(doc: Document, entry: dict[str, object], loc: Loc) -> None:
    value = entry.get("class")
    if not isinstance(value, str) or re.match(CLASS_PATTERN, value):
        return
    hint = ""
    if ":" not in value and "." in value:
        guess = value[::-1].replace(".", ":", 1)[::-1]
        if re.match(CLASS_PATTERN, guess):
            hint = f" (did you mean '{guess}'?)"
    raise DeployError(f"'class' must be module:Class (a module path, a colon, a class "
                      f"name), not {show(value)}{hint}", doc.mark(loc + ("class",)))


def _check_refs(doc: Document, section: str, entry: dict[str, object],
                loc: Loc) -> None:
    """The names in ``uses``/``allow`` (patterns allowed) and a reaction's resources."""
    for key, what in (("uses", "a resource name, entry.child or a pattern"),
                      ("allow", "a behavior name or a pattern")):
        refs = entry.get(key) if key in SPECS[section].KEYS else None
        if not isinstance(refs, dict):
            continue
        for ref in refs:
            if not re.match(REF_PATTERN, ref):
                raise DeployError(f"{quote(ref)} in {quote(key)} must be {what} (a-z, 0-9, "
                                  "_, '.', '-' and the wildcards * ? [ ] !)",
                                  doc.mark(loc + (key, ref), key=True))
            if not _BRACKETS.match(ref):
                raise DeployError(f"{quote(ref)} in {quote(key)} has a '[' or ']' without "
                                  "its pair: in a pattern, [...] holds the characters one "
                                  "place may be, e.g. 'arm[12]'",
                                  doc.mark(loc + (key, ref), key=True))
    refs = entry.get("resources") if section == "reactions" else None
    if isinstance(refs, list):
        for i, ref in enumerate(refs):
            if isinstance(ref, str) and not re.match(CHILD_PATTERN, ref):
                raise DeployError(f"'resources[{i}]' must be a resource name or entry.child "
                                  f"(lower-case names joined by '.'), not {show(ref)}",
                                  doc.mark(loc + ("resources", i)))


def _check_seconds(doc: Document, value: object, loc: Loc) -> None:
    """A duration must be > 0 (other faults -- text, inf -- are the model's to word)."""
    if isinstance(value, (int, float)) and not isinstance(value, bool) and value <= 0:
        raise DeployError(f"{quote(loc[-1])} must be greater than 0 (seconds), not {value}",
                          doc.mark(loc))


def _check_rate(doc: Document, value: object, loc: Loc) -> None:
    if (not isinstance(value, (int, float)) or isinstance(value, bool)
            or not 0 < value < float("inf")):
        raise DeployError(f"'rate_hz' must be a number greater than 0 (samples per "
                          f"second), not {show(value)}", doc.mark(loc))


def check_endpoint(text: str, doc: Document, loc: Loc = ("endpoint",)) -> None:
    """A Zenoh locator the runtime can listen on; one precise message per fault."""
    fault = endpoint_fault(text, quote(loc[-1]))
    if fault is not None:
        raise DeployError(fault, doc.mark(loc))
