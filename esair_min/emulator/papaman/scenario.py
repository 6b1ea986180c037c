"""Scenario files: the sensor board's readings over time.

A scenario is a list of steps ``(time in ms, readings)``; from each step's time on, the
sensors read those values (until the next step). Before the first step every sensor
reads ``idle`` (512 unless the file says otherwise). Two formats:

YAML::

    description: a push from the left that tips the robot
    idle: 512
    steps:
      - {at_ms: 1000, values: {left_foot: 650, right_foot: 350}}   # a group sets each of its sensors
      - {at_ms: 1400, values: [512, 512, 512, 512, 512, 512, 512, 512]}   # one per sensor
      - {at_ms: 1500, values: {l_toe_in: 530}}                     # a single sensor

CSV: a header ``t_ms,<sensor or group>,...`` and one row per step.

Errors are :class:`ConfigError` pointing at the line to change.
"""

from __future__ import annotations

import csv
import difflib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import yaml

from esair_min.errors import ConfigError, Mark, file_mark
from esair_min.model.board import Sensor

ADC_MAX = 1023
DEFAULT_IDLE = 512


@dataclass(frozen=True)
class Scenario:
    name: str
    description: str
    idle: tuple[int, ...]
    steps: tuple[tuple[int, tuple[int, ...]], ...]   # (at_ms, one value per sensor)

    def values_at(self, t_ms: float) -> tuple[int, ...]:
        current = self.idle
        for at, vals in self.steps:
            if at > t_ms:
                break
            current = vals
        return current


def quiet(sensors: Sequence[Sensor], idle: int = DEFAULT_IDLE) -> Scenario:
    """No file: every sensor reads ``idle`` for ever (a robot standing still)."""
    return Scenario("quiet", "every sensor at rest", (idle,) * len(sensors), ())


def _hint(name: str, choices: Sequence[str]) -> str:
    close = difflib.get_close_matches(name, choices, n=1)
    return f" (did you mean '{close[0]}'?)" if close else ""


class _Reader:
    def __init__(self, path: str, sensors: Sequence[Sensor]):
        self.path = path
        self.sensors = tuple(sensors)
        self.names = [s.name for s in self.sensors]
        self.groups: dict[str, list[int]] = {}
        for i, s in enumerate(self.sensors):
            self.groups.setdefault(s.group, []).append(i)

    def value(self, v: Any, mark: Mark) -> int:
        if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= ADC_MAX:
            raise ConfigError(f"sensor value {v!r} is not an integer 0..{ADC_MAX} "
                              "(10-bit ADC counts)", mark)
        return v

    def targets(self, key: str, mark: Mark) -> list[int]:
        if key in self.groups:
            return self.groups[key]
        if key in self.names:
            return [self.names.index(key)]
        choices = self.names + list(self.groups)
        raise ConfigError(f"no sensor or sensor group named '{key}'{_hint(key, choices)}",
                          mark)

    def apply(self, prev: tuple[int, ...], values: Any, mark: Mark) -> tuple[int, ...]:
        out = list(prev)
        if isinstance(values, list):
            if len(values) != len(self.sensors):
                raise ConfigError(f"expected {len(self.sensors)} values (one per sensor, in "
                                  f"register order), got {len(values)}", mark)
            return tuple(self.value(v, mark) for v in values)
        if isinstance(values, dict):
            for key, v in values.items():
                for i in self.targets(str(key), mark):
                    out[i] = self.value(v, mark)
            return tuple(out)
        raise ConfigError("'values' must be a list (one per sensor) or a mapping of "
                          "sensor or group names to values", mark)


def _node_mark(path: str, node: yaml.Node) -> Mark:
    return Mark(path, node.start_mark.line + 1, node.start_mark.column + 1)


def _load_yaml(path: str, text: str, r: _Reader) -> Scenario:
    try:
        node = yaml.compose(text, Loader=yaml.SafeLoader)
        data = yaml.safe_load(text)
    except yaml.MarkedYAMLError as exc:
        from esair_min.config.yamlerrors import explain

        plain = explain(exc, text)
        if plain is not None:
            raise ConfigError(plain.message, Mark(path, plain.line + 1, plain.col + 1)) from None
        m = exc.problem_mark
        mark = Mark(path, m.line + 1, m.column + 1) if m else file_mark(path)
        raise ConfigError(f"YAML syntax error: {exc.problem}", mark) from None
    if node is None or not isinstance(data, dict) or not isinstance(data.get("steps"), list):
        raise ConfigError("a scenario file is a mapping with 'steps:', a list of "
                          "{at_ms: ..., values: ...}", file_mark(path))
    step_nodes = next(v for k, v in node.value if k.value == "steps").value
    idle_v = data.get("idle", DEFAULT_IDLE)
    idle = (r.value(idle_v, file_mark(path)),) * len(r.sensors)
    steps: list[tuple[int, tuple[int, ...]]] = []
    prev, last_t = idle, -1
    for step, snode in zip(data["steps"], step_nodes):
        mark = _node_mark(path, snode)
        if not isinstance(step, dict) or set(step) != {"at_ms", "values"}:
            raise ConfigError("each step is {at_ms: <time in ms>, values: <readings>}", mark)
        t = step["at_ms"]
        if isinstance(t, bool) or not isinstance(t, int) or t <= last_t:
            raise ConfigError(f"at_ms {t!r} must be a whole number of ms, later than the "
                              "step before", mark)
        prev = r.apply(prev, step["values"], mark)
        steps.append((t, prev))
        last_t = t
    return Scenario(Path(path).stem, str(data.get("description", "")), idle, tuple(steps))


def _load_csv(path: str, text: str, r: _Reader) -> Scenario:
    rows = [row for row in csv.reader(text.splitlines()) if row and not row[0].startswith("#")]
    if not rows or rows[0][0].strip() != "t_ms":
        raise ConfigError("a CSV scenario starts with a header 't_ms,<sensor or group>,...'",
                          file_mark(path))
    header = [h.strip() for h in rows[0]]
    idle = (DEFAULT_IDLE,) * len(r.sensors)
    prev, last_t = idle, -1
    steps: list[tuple[int, tuple[int, ...]]] = []
    lines = [i + 1 for i, line in enumerate(text.splitlines())
             if line.strip() and not line.startswith("#")]
    for row, line in zip(rows[1:], lines[1:]):
        mark = Mark(path, line, 1)
        if len(row) != len(header):
            raise ConfigError(f"expected {len(header)} columns as in the header, got {len(row)}",
                              mark)
        try:
            t = int(row[0])
            vals = {h: int(v) for h, v in zip(header[1:], row[1:])}
        except ValueError:
            raise ConfigError("every column of a CSV scenario is a whole number", mark) from None
        if t <= last_t:
            raise ConfigError(f"at_ms {t!r} must be a whole number of ms, later than the "
                              "step before", mark)
        prev = r.apply(prev, vals, mark)
        steps.append((t, prev))
        last_t = t
    return Scenario(Path(path).stem, "", idle, tuple(steps))


def load_scenario(path: Path | str, sensors: Sequence[Sensor]) -> Scenario:
    """Read a YAML (``.yaml``/``.yml``) or CSV (``.csv``) scenario for these sensors."""
    p = Path(path)
    name = str(path)
    if not p.is_file():
        raise ConfigError("no such scenario file", file_mark(name))
    text = p.read_text(encoding="utf-8", errors="replace")
    r = _Reader(name, sensors)
    if p.suffix.lower() == ".csv":
        return _load_csv(name, text, r)
    return _load_yaml(name, text, r)


def scenario_dir(robot_source: str) -> Path:
    src = Path(robot_source)
    return (src if src.is_dir() else src.parent) / "scenarios"


def resolve_scenario(arg: str, robot_source: str) -> Path:
    """A scenario path as given, or the name of one in the robot's ``scenarios/`` folder."""
    p = Path(arg)
    if p.is_file():
        return p
    folder = scenario_dir(robot_source)
    for ext in (".yaml", ".yml", ".csv"):
        cand = folder / f"{arg}{ext}"
        if cand.is_file():
            return cand
    known = sorted(f.stem for f in folder.glob("*.*")) if folder.is_dir() else []
    listing = ", ".join(known) if known else "none"
    raise ConfigError(f"no scenario '{arg}'{_hint(arg, known)}: give a file, or one of "
                      f"the robot's scenarios ({listing})")
