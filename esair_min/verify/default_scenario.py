"""The default scenario of ``esair verify``: a stimulus script (docs/trace-format.md)
generated from a robot's board files.

Every command of the central board's table with its arguments at and beyond each limit,
every motion played (and stopped), every reaction fired, the sensors read, and the error
paths: a bad line (unknown, too long, a bad character, a bad checksum), a missing slave
(the sensor board stops answering) and, when the baud makes it possible, an overrun of
the 64-byte receive ring. Each line is followed by enough ticks for its bytes and its
reply to cross the UART at the board's baud, so a simulator (bytes at line rate) and the
Python core (bytes at once) see the same order of events per device.

The scenario runs on every target, so it stays within what the chip simulators' stand-ins
can do (docs/verify.md): no write NACKs (gpsim cannot make one), and on the PIC with a
sensor board outside 0x50..0x57 equal readings only, so no reaction fires there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from esair_min.core.protocol import add_checksum
from esair_min.model.encoding import MAX_LINE
from esair_min.model.robot import Robot

MAX_SPEED = 25               # speed letters a..z
RING = 64                    # the central board's receive ring (bytes)
REPLY_MAX = 80               # bytes of the longest reply, with its line end
LEVEL = 514                  # a reading gpsim's one-byte sensor stand-in can give (2 + 2*256)


@dataclass
class Scenario:
    """The script and what it covers (``skipped``: paths it could not take, and why)."""

    text: str
    covers: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)


def _tick_s(robot: Robot) -> float:
    t = robot.central.timer2
    assert t is not None
    return float(t.period_s)


def settle_ticks(robot: Robot, sent: int, reply: int = REPLY_MAX) -> int:
    """Ticks for ``sent`` bytes and a reply of ``reply`` bytes to cross the UART, plus 2."""
    uart = robot.central.uart
    assert uart is not None
    seconds = (sent + reply) * 10 / uart.baud
    return math.ceil(seconds / _tick_s(robot)) + 2


def can_tip(robot: Robot, targets: tuple[str, ...]) -> bool:
    """Whether every target's sensor board can give unequal readings (gpsim's stand-in
    for a board outside 0x50..0x57 answers one byte for every register)."""
    sen = robot.peer("sensor")
    if sen is None:
        return False
    return "pic" not in targets or (sen.address & 0x78 == 0x50
                                    and robot.eeprom is not None
                                    and sen.address != robot.eeprom.address)


class _Writer:
    def __init__(self, robot: Robot):
        self.robot = robot
        self.lines: list[str] = []
        uart = robot.central.uart
        self.checksum = bool(uart is not None and uart.require_checksum)
        self.ticks = 0                  # ticks since boot

    def comment(self, text: str) -> None:
        self.lines.append(f"# {text}")

    def send(self, line: str, ticks: int | None = None, raw: bool = False) -> None:
        """One command line (CR ended; with its checksum when the board requires one),
        then the ticks its bytes and reply need."""
        text = line if raw or not self.checksum else add_checksum(line)
        self.lines.append(f"rx {_escape(text)}\\r")
        self.tick(ticks if ticks is not None else settle_ticks(self.robot, len(text) + 1))

    def tick(self, n: int) -> None:
        self.lines.append(f"tick {n}")
        self.ticks += n

    def between_polls(self) -> None:
        """Ticks until the last one is no reaction's poll tick, so a change of the sensor
        board (readings, a fault) that follows cannot cut a poll's read in a chip (its
        script stands early in the tick after the last one, while the read may still run)."""
        polls = [r.poll_ticks for r in self.robot.central.reactions]
        if polls and min(polls) >= 3:
            period = min(polls)
            k = (2 - self.ticks) % period
            if k:
                self.tick(k)


def _escape(text: str) -> str:
    return "".join(c if " " <= c <= "~" and c != "\\" else f"\\x{ord(c):02X}" for c in text)


def _letter(i: int) -> str:
    return chr(ord("a") + i)


def _angle_code(angle: int) -> str | None:
    """The ``c`` command's character for ``angle`` (3-degree steps), None if none."""
    return chr(0x30 + angle // 3) if angle % 3 == 0 and 0 <= angle <= 180 else None


def _image_link(w: _Writer, sc: Scenario, robot: Robot, by_action: dict[str, list[str]],
                targets: tuple[str, ...]) -> None:
    """The motion image's verbs over the link (docs/protocol.md), where the table has
    them: reads at and beyond their limits, refused writes (a bad checksum, a chunk with
    no header written first: the image stays as it is), a commit of the valid image, the
    I2C scan."""
    from esair_min.core import protocol

    read_max = int(getattr(protocol, "READ_MAX", 16))
    size = robot.eeprom.size_bytes if robot.eeprom is not None else 0
    for prefix in by_action.get("image_read", []):
        w.comment(f"image read: '{prefix}', 1 and {read_max} bytes, 0 and {read_max + 1}, "
                  "past the EEPROM's end")
        w.send(f"{prefix}000001")
        w.send(f"{prefix}0000{read_max:02X}")
        w.send(f"{prefix}000000")
        w.send(f"{prefix}0000{read_max + 1:02X}")
        if size:
            w.send(f"{prefix}{min(size - 1, 0xFFFF):04X}02")
        sc.covers.append(f"{prefix} (image read: 1, {read_max}, beyond)")
    for prefix in by_action.get("image_write", []):
        w.comment(f"image write: '{prefix}' refused (a bad checksum; a chunk before the header)")
        at, data = 0x0040, b"\x00"
        good = -((at >> 8) + (at & 0xFF) + sum(data)) & 0xFF
        w.send(f"{prefix}{at:04X}{data.hex().upper()}{(good + 1) & 0xFF:02X}")
        w.send(f"{prefix}{at:04X}{data.hex().upper()}{good:02X}")
        sc.covers.append(f"{prefix} (image write: E06, E03)")
    for prefix in by_action.get("image_commit", []):
        w.comment(f"image commit: '{prefix}' with no write open (the image is checked)")
        from esair_min.core.image import build_image

        check_s = (len(build_image(robot)) + 32) * 9 * 1.3 / robot.central.i2c.speed_hz
        w.send(prefix, settle_ticks(robot, len(prefix) + 1) + math.ceil(check_s / _tick_s(robot)))
        sc.covers.append(f"{prefix} (image commit)")
    for prefix in by_action.get("i2c_scan", []):
        if "pic" in targets:
            sc.skipped.append(f"{prefix} (i2c scan): gpsim's MSSP master drives SDA through "
                              "the ACK clock, so every address would seem to answer (drop "
                              "pic from --targets to scan)")
            continue
        w.comment(f"i2c scan: '{prefix}'")
        w.send(prefix, settle_ticks(robot, 2) + 2)
        sc.covers.append(f"{prefix} (i2c scan)")


def default_scenario(robot: Robot, targets: tuple[str, ...]) -> Scenario:
    """The generated scenario for ``robot`` on ``targets`` (see the module's doc)."""
    w = _Writer(robot)
    sc = Scenario("")
    servos = robot.servos
    n_sensors = len(robot.sensors)
    central = robot.central
    tip = can_tip(robot, targets)
    if n_sensors:
        w.lines.append("sensor " + " ".join([str(LEVEL)] * n_sensors))
    w.lines.append("boot")
    w.tick(4)
    by_action: dict[str, list[str]] = {}
    for cmd in robot.commands:
        by_action.setdefault(cmd.action, []).append(cmd.prefix)
        if cmd.action == "play" and cmd.motion is not None:
            by_action.setdefault("fixed", []).append(cmd.prefix)
    motions = {m.name: m for m in robot.motions}

    def motion_ticks(name: str) -> int:
        m = motions[name]
        return len(m.frames) * m.delay_ticks + settle_ticks(robot, 8)

    for prefix in by_action.get("version", []):
        w.comment(f"version: '{prefix}'")
        w.send(prefix)
        sc.covers.append(f"{prefix} (version)")
    for prefix in by_action.get("stand", []):
        w.comment(f"stand: '{prefix}' (a held write at the next tick)")
        w.send(prefix)
        sc.covers.append(f"{prefix} (stand)")
    for prefix in by_action.get("motor", []):
        w.comment(f"one motor: '{prefix}', each servo at its limits and one beyond")
        for s in servos:
            m = _letter(s.index)
            for angle in (s.min_angle, s.max_angle):
                w.send(f"{prefix}{m}a{angle:03d}")
            for angle in (s.min_angle - 1, s.max_angle + 1):
                if 0 <= angle <= 999:
                    w.send(f"{prefix}{m}a{angle:03d}")
        s0 = servos[0]
        w.send(f"{prefix}a{_letter(MAX_SPEED)}{s0.stand_angle:03d}")        # top speed
        w.send(f"{prefix}a{{{s0.stand_angle:03d}")                         # speed 26
        w.send(f"{prefix}{_letter(len(servos))}a{s0.stand_angle:03d}")    # no such motor
        w.send(f"{prefix}aa{s0.stand_angle:02d}")                          # too short
        sc.covers.append(f"{prefix} (motor: {len(servos)} servos at and beyond their limits, "
                         "speed 25 and 26, a motor beyond the last)")
    for prefix in by_action.get("speeds", []):
        w.comment(f"speeds: '{prefix}' at 0, at the top ({MAX_SPEED}), one beyond")
        n = len(servos)
        w.send(prefix + "000" * n)
        w.send(prefix + f"{MAX_SPEED:03d}" * n)
        w.send(prefix + f"{MAX_SPEED:03d}" * (n - 1) + f"{MAX_SPEED + 1:03d}")
        w.send(prefix + "003" * n)
        sc.covers.append(f"{prefix} (speeds: 0, {MAX_SPEED}, {MAX_SPEED + 1})")
    for prefix in by_action.get("angles", []):
        w.comment(f"angles: '{prefix}', every servo at its lower then upper limit, one beyond")
        lows = [_angle_code(-(-s.min_angle // 3) * 3) or "." for s in servos]
        highs = [_angle_code(s.max_angle // 3 * 3) or "." for s in servos]
        w.send(prefix + "".join(lows))
        w.send(prefix + "".join(highs))
        beyond = next((s for s in servos if s.max_angle + 3 <= 180), None)
        if beyond is not None:
            codes = ["."] * len(servos)
            codes[beyond.index] = _angle_code((beyond.max_angle // 3 + 1) * 3) or "."
            w.send(prefix + "".join(codes))
        w.send(prefix + "m" + "." * (len(servos) - 1))                     # a code beyond 'l'
        w.send(prefix + "." * len(servos))
        sc.covers.append(f"{prefix} (angles: limits, beyond, a bad code)")
    for prefix in by_action.get("sensors", []):
        w.comment(f"sensors: '{prefix}'")
        w.send(prefix)
        sc.covers.append(f"{prefix} (sensors)")
    _image_link(w, sc, robot, by_action, targets)
    stop = by_action["stop"][0] if by_action.get("stop") else None
    play = [p for p in by_action.get("play", []) if p not in by_action.get("fixed", [])]
    for prefix in play:
        for m in robot.motions:
            w.comment(f"motion '{m.name}' played whole: '{prefix}{m.number:02d}'")
            w.send(f"{prefix}{m.number:02d}", motion_ticks(m.name))
        used = {m.number for m in robot.motions}
        free = next((k for k in range(99, -1, -1) if k not in used), None)
        if free is not None:
            w.send(f"{prefix}{free:02d}")                                   # no such motion
        w.send(prefix)                                                     # too short
        sc.covers.append(f"{prefix} (play: {len(robot.motions)} motions, one missing)")
    longest = max(robot.motions, key=lambda m: len(m.frames) * m.delay_ticks, default=None)
    for cmd in robot.commands:
        if cmd.action == "play" and cmd.motion is not None:
            w.comment(f"'{cmd.prefix}' plays '{cmd.motion}'; a second motion is busy; stopped")
            w.send(cmd.prefix, 2)
            if longest is not None and play:
                w.send(f"{play[0]}{longest.number:02d}", 2)
            if stop:
                w.send(stop, 4)
            w.send(cmd.prefix, motion_ticks(cmd.motion))
            sc.covers.append(f"{cmd.prefix} (play '{cmd.motion}', busy, stop)")
    if stop:
        w.comment(f"stop: '{stop}' while idle")
        w.send(stop)
        sc.covers.append(f"{stop} (stop)")
    w.comment("bad lines: unknown, too long, a bad character, checksums")
    w.send("?", raw=True)
    w.send("0123456789" * 4 + "01234", raw=True)
    stand = (by_action.get("stand") or by_action.get("version") or ["?"])[0]
    w.send(stand + "\x01", raw=True)
    w.send(add_checksum(stand), raw=True)
    good = add_checksum(stand)
    w.send(good[:-1] + ("0" if good[-1] != "0" else "1"), raw=True)
    sc.covers.append("bad lines: E01, E02, E13, E06, a good checksum")

    def tip_each(held: bool) -> None:
        for r in central.reactions:
            a = [i for i, x in enumerate(robot.sensors) if x.group == r.compare[0]]
            b = [i for i, x in enumerate(robot.sensors) if x.group == r.compare[1]]
            readings = [LEVEL] * n_sensors
            high = min(1023, LEVEL + r.threshold // max(1, len(a)) + 1)
            low = max(0, LEVEL - r.threshold // max(1, len(b)) - 1)
            for i in a:
                readings[i] = high
            for i in b:
                readings[i] = low
            w.comment(f"reaction '{r.name}'{' (held)' if held else ''}: "
                      f"'{r.compare[0]}' heavier than '{r.compare[1]}' by more "
                      f"than {r.threshold}")
            w.between_polls()
            w.lines.append("sensor " + " ".join(map(str, readings)))
            w.tick(r.poll_ticks * (r.samples + 1)
                   + (0 if held else motion_ticks(r.motion)))
            w.between_polls()
            w.lines.append("sensor " + " ".join([str(LEVEL)] * n_sensors))
            w.tick(r.poll_ticks * 2)
            if not held:
                sc.covers.append(f"reaction {r.name}")

    if central.reactions and n_sensors:
        if tip:
            tip_each(False)
        else:
            sc.skipped.append("reactions: gpsim's stand-in for a sensor board outside "
                              "0x50..0x57 answers the same byte for every register, so the "
                              "readings cannot tip (drop pic from --targets to fire them)")
    for prefix in by_action.get("hold", []):
        tipped = tip and bool(central.reactions) and n_sensors > 0
        w.comment(f"reactions held: '{prefix}1'" + (", each tipped (!H, nothing moves)"
                                                    if tipped else "")
                  + f", '{prefix}2' refused, '{prefix}0'")
        w.send(f"{prefix}1")
        if tipped:
            tip_each(True)
        w.send(f"{prefix}2")
        w.send(f"{prefix}0")
        sc.covers.append(f"{prefix} (hold{': each reaction held' if tipped else ''}, "
                         "E03, released)")
    if robot.peer("sensor") is not None and by_action.get("sensors"):
        w.comment("a missing slave: the sensor board stops answering")
        w.between_polls()
        w.lines.append("fault sensor on")
        polls = max((r.poll_ticks for r in central.reactions), default=0)
        if polls:                   # a poll fails first: its notice, then the command's E10
            w.tick(2 * polls + settle_ticks(robot, 0))
        w.send(by_action["sensors"][0])
        w.between_polls()
        w.lines.append("fault sensor off")
        if polls:
            w.tick(2 * polls + settle_ticks(robot, 0))
        w.send(by_action["sensors"][0])
        sc.covers.append("missing slave (E10)")
    per_tick = central.uart.baud / 10 * _tick_s(robot) if central.uart else 0
    if per_tick >= RING + 20 and "stand" in by_action and "version" in by_action:
        v, t = by_action["version"][0], by_action["stand"][0]
        w.comment("overrun: a held write stops the decoder while the 64-byte ring fills")
        burst = t + "\r" + (v + "\r") * 27 + "c" + "T" * 12
        w.lines.append(f"rx {_escape(burst)}\\r")
        w.tick(settle_ticks(robot, len(burst), REPLY_MAX * 28))
        w.send(t)
        sc.covers.append("overrun (E12)")
    else:
        sc.skipped.append(f"overrun: at {central.uart.baud if central.uart else 0} baud only "
                          f"{per_tick:.0f} bytes arrive in a tick, the 64-byte ring cannot "
                          "fill behind a held write")
    assert all(len(line) < 4 * MAX_LINE + 400 for line in w.lines)
    sc.text = "\n".join(w.lines) + "\n"
    return sc
