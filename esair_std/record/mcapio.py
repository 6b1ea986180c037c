"""MCAP recordings (docs/hmi.md, docs/foxglove.md): what :mod:`.foxmsgs` makes of a
running robot, written with the ``mcap`` library. Each sensor keeps a channel of its own
(topic = its name, messages ``{"seq", "t", "value"}``, JSON schema ``esair.Sample.<sensor>``
giving the value's fields; files before them: one schema :data:`SCHEMA`); commands, one
channel per actuator (topic ``command/<actuator>``, ``{"seq", "t", "command", "ok" |
"error"}``, schema :data:`COMMAND_SCHEMA`, log time = when the command reached the
actuator's host); the latched STOP's state (docs/std.md), channel ``latch``, ``{"seq",
"t", "stopped", ...}`` under :data:`LATCH_SCHEMA`; and the Foxglove-native channels.
The readers here read the samples, commands and latch of both kinds of file."""

from __future__ import annotations

import json
from pathlib import Path
from typing import BinaryIO, Iterator, cast

from mcap.reader import make_reader
from mcap.writer import Writer

from ..errors import StdError
from ..transport.codec import JSON, JSONObject
from .foxmsgs import COMMAND, LATCH, LATCH_TOPIC, Converter, Out

SCHEMA = {"type": "object", "title": "esair.Sample",
          "properties": {"seq": {"type": "integer", "description": "the sensor's sample number, from 1"},
                         "t": {"type": "number", "description": "seconds since the epoch, when reported"},
                         "value": {"description": "the sensor's value"}},
          "required": ["seq", "t", "value"]}


COMMAND_SCHEMA = json.loads(COMMAND.data)
COMMAND_TOPIC = "command/"
LATCH_SCHEMA = json.loads(LATCH.data)


class SampleWriter:
    """Writes :class:`~.foxmsgs.Out` messages: a schema registered once per name, a
    channel once per topic; the samples' and commands' own numbers as the sequence."""

    def __init__(self, f: BinaryIO):
        self.w = Writer(f)
        self.w.start(profile="", library="esair")
        self.conv = Converter()
        self.channels: dict[str, int] = {}
        self.data_channels = 0        # the samples', commands', latch's (what `record` counts)
        self._schemas: dict[str, int] = {}

    def put(self, out: Out) -> None:
        ch = self.channels.get(out.topic)
        if ch is None:
            sid = self._schemas.get(out.schema.name)
            if sid is None:
                sid = self._schemas[out.schema.name] = self.w.register_schema(
                    name=out.schema.name, encoding=out.schema.encoding, data=out.schema.data)
            ch = self.channels[out.topic] = self.w.register_channel(
                topic=out.topic, message_encoding=out.schema.message_encoding, schema_id=sid)
            self.data_channels += out.schema.name.startswith(("esair.Sample.", "esair.Command",
                                                              "esair.Latch"))
        ns = int(out.t * 1e9)
        self.w.add_message(channel_id=ch, log_time=ns, publish_time=ns,
                           sequence=out.seq & 0xFFFFFFFF, data=out.data)

    def write(self, topic: str, seq: int, t: float, value: JSON) -> None:
        """One sample of the sensor ``topic``, and the native messages made of it."""
        for out in self.conv.sample(topic, seq, t, value):
            self.put(out)

    def write_message(self, msg: JSONObject) -> None:
        """A bridge message that is no sample: a log line, a behavior's state, the link."""
        for out in self.conv.message(msg):
            self.put(out)

    def write_command(self, actuator: str, seq: int, t: float, record: JSONObject) -> None:
        """One command ``record`` ({command, ok | error}) of ``actuator``."""
        for out in self.conv.command(actuator, seq, t, record):
            self.put(out)

    def write_latch(self, seq: int, t: float, state: JSONObject) -> None:
        """One state of the latched STOP (``{"stopped", "by", "reason", ...}``)."""
        self.put(Out(LATCH_TOPIC, LATCH, json.dumps(dict(state, seq=seq, t=t),
                                                    separators=(",", ":")).encode(), t, seq))

    def finish(self) -> None:
        self.w.finish()


def read_samples(path: str | Path) -> Iterator[tuple[str, int, float, JSON]]:
    """(topic, seq, t, value) of every sample, in log time order (commands left out)."""
    for kind, topic, seq, t, value in _read(path):
        if kind == "sample":
            yield topic, seq, t, value


def read_commands(path: str | Path) -> Iterator[tuple[str, int, float, JSONObject]]:
    """(actuator, seq, t, {command, ok | error}) of every command, in log time order."""
    for kind, topic, seq, t, value in _read(path):
        if kind == "command":
            yield topic, seq, t, cast(JSONObject, value)     # _read made it an object


def read_latch(path: str | Path) -> Iterator[tuple[float, JSONObject]]:
    """(t, state) of every state of the latched STOP recorded, in log time order."""
    for kind, _topic, _seq, t, value in _read(path):
        if kind == "latch":
            yield t, cast(JSONObject, value)                 # _read made it an object


def _read(path: str | Path) -> Iterator[tuple[str, str, int, float, JSON]]:
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
                name = _schema.name if _schema is not None else "esair.Sample"
                if name == "esair.Latch":
                    yield ("latch", channel.topic, int(m["seq"]), float(m["t"]),
                           {k: v for k, v in m.items() if k not in ("seq", "t")})
                elif name == "esair.Command":
                    rec = {k: v for k, v in m.items() if k not in ("seq", "t")}
                    yield ("command", channel.topic[len(COMMAND_TOPIC):], int(m["seq"]),
                           float(m["t"]), rec)
                elif name == "esair.Sample" or name.startswith("esair.Sample."):
                    yield "sample", channel.topic, int(m["seq"]), float(m["t"]), m["value"]
        except (ValueError, KeyError, TypeError) as exc:
            raise StdError(f"{path} is not an MCAP recording of ESAIR samples: {exc}") from None
        except Exception as exc:  # noqa: BLE001 - the mcap reader's own errors
            raise StdError(f"{path} is not a readable MCAP file: {exc}") from None
