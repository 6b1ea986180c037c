"""MCAP files of samples: one channel per sensor, messages ``{"seq", "t", "value"}``
encoded as JSON under the JSON schema :data:`SCHEMA`; log time = the sample's time.
Commands, one channel per actuator (topic ``command/<actuator>``), messages ``{"seq",
"t", "command", "ok" | "error"}`` under :data:`COMMAND_SCHEMA`; log time = when the
command reached the actuator's host. The latched STOP's state (docs/std.md), one
channel ``latch``, messages ``{"seq", "t", "stopped", ...}`` under :data:`LATCH_SCHEMA`
(at the recording's start when the robot is STOPPED then, and at each change)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, BinaryIO, Iterator

from mcap.reader import make_reader
from mcap.writer import Writer

from ..errors import StdError

SCHEMA = {"type": "object", "title": "esair.Sample",
          "properties": {"seq": {"type": "integer", "description": "the sensor's sample number, from 1"},
                         "t": {"type": "number", "description": "seconds since the epoch, when reported"},
                         "value": {"description": "the sensor's value"}},
          "required": ["seq", "t", "value"]}


COMMAND_SCHEMA = {
    "type": "object", "title": "esair.Command",
    "properties": {"seq": {"type": "integer", "description": "the actuator's command number, from 1"},
                   "t": {"type": "number", "description": "seconds since the epoch, when it reached "
                                                          "the actuator's host"},
                   "command": {"description": "the command as sent"},
                   "ok": {"description": "the actuator's answer (the command ran)"},
                   "error": {"type": "string", "description": "why it failed"}},
    "required": ["seq", "t", "command"]}
COMMAND_TOPIC = "command/"
LATCH_TOPIC = "latch"
LATCH_SCHEMA = {
    "type": "object", "title": "esair.Latch",
    "properties": {"seq": {"type": "integer", "description": "the state's number, from 1"},
                   "t": {"type": "number", "description": "seconds since the epoch: the STOP "
                                                          "or the release"},
                   "stopped": {"type": "boolean"},
                   "by": {"type": "string", "description": "who STOPPED it"},
                   "reason": {"type": "string"},
                   "released_by": {"type": "string", "description": "who released it"}},
    "required": ["seq", "t", "stopped"]}


class SampleWriter:
    def __init__(self, f: BinaryIO):
        self.w = Writer(f)
        self.w.start(profile="", library="esair")
        self.schema = self.w.register_schema(name="esair.Sample", encoding="jsonschema",
                                             data=json.dumps(SCHEMA).encode())
        self.channels: dict[str, int] = {}
        self._command_schema: int | None = None

    def write(self, topic: str, seq: int, t: float, value: Any) -> None:
        ch = self.channels.get(topic)
        if ch is None:
            ch = self.channels[topic] = self.w.register_channel(
                topic=topic, message_encoding="json", schema_id=self.schema)
        ns = int(t * 1e9)
        self.w.add_message(channel_id=ch, log_time=ns, publish_time=ns, sequence=seq & 0xFFFFFFFF,
                           data=json.dumps({"seq": seq, "t": t, "value": value},
                                           separators=(",", ":")).encode())

    def write_command(self, actuator: str, seq: int, t: float, record: dict) -> None:
        """One command ``record`` ({command, ok | error}) of ``actuator``."""
        topic = COMMAND_TOPIC + actuator
        ch = self.channels.get(topic)
        if ch is None:
            if self._command_schema is None:
                self._command_schema = self.w.register_schema(
                    name="esair.Command", encoding="jsonschema",
                    data=json.dumps(COMMAND_SCHEMA).encode())
            ch = self.channels[topic] = self.w.register_channel(
                topic=topic, message_encoding="json", schema_id=self._command_schema)
        ns = int(t * 1e9)
        self.w.add_message(channel_id=ch, log_time=ns, publish_time=ns, sequence=seq & 0xFFFFFFFF,
                           data=json.dumps(dict(record, seq=seq, t=t),
                                           separators=(",", ":")).encode())

    def write_latch(self, seq: int, t: float, state: dict) -> None:
        """One state of the latched STOP (``{"stopped", "by", "reason", ...}``)."""
        ch = self.channels.get(LATCH_TOPIC)
        if ch is None:
            schema = self.w.register_schema(name="esair.Latch", encoding="jsonschema",
                                            data=json.dumps(LATCH_SCHEMA).encode())
            ch = self.channels[LATCH_TOPIC] = self.w.register_channel(
                topic=LATCH_TOPIC, message_encoding="json", schema_id=schema)
        ns = int(t * 1e9)
        self.w.add_message(channel_id=ch, log_time=ns, publish_time=ns, sequence=seq,
                           data=json.dumps(dict(state, seq=seq, t=t),
                                           separators=(",", ":")).encode())

    def finish(self) -> None:
        self.w.finish()


def read_samples(path: str | Path) -> Iterator[tuple[str, int, float, Any]]:
    """(topic, seq, t, value) of every sample, in log time order (commands left out)."""
    for kind, topic, seq, t, value in _read(path):
        if kind == "sample":
            yield topic, seq, t, value


def read_commands(path: str | Path) -> Iterator[tuple[str, int, float, dict]]:
    """(actuator, seq, t, {command, ok | error}) of every command, in log time order."""
    for kind, topic, seq, t, value in _read(path):
        if kind == "command":
            yield topic, seq, t, value


def read_latch(path: str | Path) -> Iterator[tuple[float, dict]]:
    """(t, state) of every state of the latched STOP recorded, in log time order."""
    for kind, _topic, _seq, t, value in _read(path):
        if kind == "latch":
            yield t, value


def _read(path: str | Path) -> Iterator[tuple[str, str, int, float, Any]]:
    try:
        f = open(path, "rb")  # noqa: SIM115 - closed by the with below
    except OSError as exc:
        raise StdError(f"cannot read {path}: {exc.strerror}") from None
    with f:
        try:
            for _schema, channel, message in make_reader(f).iter_messages(log_time_order=True):
                if channel.message_encoding != "json":
                    continue
                m = json.loads(message.data)
                if _schema is not None and _schema.name == "esair.Latch":
                    yield ("latch", channel.topic, int(m["seq"]), float(m["t"]),
                           {k: v for k, v in m.items() if k not in ("seq", "t")})
                elif _schema is not None and _schema.name == "esair.Command":
                    rec = {k: v for k, v in m.items() if k not in ("seq", "t")}
                    yield ("command", channel.topic[len(COMMAND_TOPIC):], int(m["seq"]),
                           float(m["t"]), rec)
                else:
                    yield "sample", channel.topic, int(m["seq"]), float(m["t"]), m["value"]
        except (ValueError, KeyError, TypeError) as exc:
            raise StdError(f"{path} is not an MCAP recording of ESAIR samples: {exc}") from None
        except Exception as exc:  # noqa: BLE001 - the mcap reader's own errors
            raise StdError(f"{path} is not a readable MCAP file: {exc}") from None
