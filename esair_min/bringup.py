"""``esair doctor``: the bring-up checklist of a real robot's central board, each check
passed or failed with the hint a builder needs (docs/hardware.md, "Bring-up").

The checks run in order and stop where the next ones could only fail for the same
reason (no port, no reply): the port opens; the board answers ``v`` at the board file's
baud (or which common baud answered instead); the reply is this robot's (counts of
servos, sensors, motions), its firmware is the one these board files build (build id)
and its motion image is theirs (CRC); every I2C device the board files declare
acknowledges (``i``); each sensor reads inside its range (``s``); with ``move``, each
servo in turn moved a few degrees around its stand angle, slowly, inside its limits.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable, Generator, Iterator

from esair_min.core import protocol as P
from esair_min.core.image import build_image, header_of
from esair_min.model.robot import Robot

#: Bauds tried when the board file's gets no reply, most common first.
COMMON_BAUDS = (9600, 19200, 38400, 57600, 115200, 4800, 2400)
#: Degrees a servo is moved each way from its stand angle with ``move``.
MOVE_DEGREES = 5
#: Speed code of the moves (degrees per sync tick): slow enough to watch.
MOVE_SPEED = 1


@dataclass(frozen=True)
class Check:
    name: str          # what was checked ("port", "reply", "firmware", ...)
    ok: bool
    detail: str        # what was seen
    hint: str = ""     # what to do about a failure

    def lines(self) -> list[str]:
        out = [f"{'PASS' if self.ok else 'FAIL'}  {self.name}: {self.detail}"]
        if self.hint:
            out.append(f"      hint: {self.hint}")
        return out


class _Link:
    """Lines to and from the board over an open pySerial port."""

    def __init__(self, ser: Any, timeout: float):
        self.ser = ser
        self.timeout = timeout

    def ask(self, line: str, timeout: float | None = None, want: str = "") -> str | None:
        """The reply to ``line`` (notices skipped; with ``want``, the first reply that
        starts with it), None if none came in time."""
        self.ser.reset_input_buffer()
        # a line end first with ``want``: it ends whatever garbage came before (bytes
        # sent at a wrong baud), whose error reply is then skipped
        self.ser.write((b"\r\n" if want else b"") + line.encode("ascii") + b"\r\n")
        deadline = time.monotonic() + (self.timeout if timeout is None else timeout)
        buf = bytearray()
        while time.monotonic() < deadline:
            buf += self.ser.read(self.ser.in_waiting or 1)
            while b"\n" in buf:
                raw, _, rest = bytes(buf).partition(b"\n")
                buf = bytearray(rest)
                text = raw.decode("latin-1").strip()
                if text.startswith(want or ("OK", "E")) and text.isprintable():
                    return text
        return None


class Doctor:
    """The checks of ``robot`` on the board behind ``ser`` (opened at ``baud``)."""

    def __init__(self, robot: Robot, ser: Any, port: str, baud: int, timeout: float = 2.0):
        self.robot = robot
        self.ser = ser
        self.port = port
        self.baud = baud
        self.link = _Link(ser, timeout)
        self.prefix = {c.action: c.prefix for c in robot.commands}

    def run(self, move: bool = False,
            on_move: Callable[[str], None] | None = None) -> Iterator[Check]:
        fields = yield from self._reply()
        if fields is None:
            return
        if not (yield from self._identity(fields)):
            return
        yield from self._image(fields)
        yield from self._i2c()
        yield from self._sensors()
        if move:
            yield from self._move(on_move)

    # -- the reply ---------------------------------------------------------------------
    def _version(self) -> str | None:
        reply = self.link.ask(self.prefix.get("version", "v"))
        if reply is None:            # a board that resets on open is still booting
            reply = self.link.ask(self.prefix.get("version", "v"))
        return reply

    def _reply(self) -> Generator[Check, None, dict[str, str] | None]:
        reply = self._version()
        if reply is not None and reply.startswith("OK "):
            yield Check("reply", True, f"the board answers 'v' at {self.baud} baud")
            return P.version_fields(reply[3:]) | {"_words": reply[3:]}
        if reply is not None:
            yield Check("reply", False, f"the board answers 'v' with {reply!r}",
                        "ESAIR's firmware answers 'v' with OK: flash it (esair flash "
                        f"{self.robot.name} --board central --port {self.port})")
            return None
        for baud in COMMON_BAUDS:
            if baud == self.baud:
                continue
            self.ser.baudrate = baud
            reply = self.link.ask("v", timeout=min(1.0, self.link.timeout), want="OK esair-min")
            if reply is not None:
                yield Check("reply", False,
                            f"no reply at {self.baud} baud (the board file's); the board "
                            f"answers at {baud} baud",
                            f"the firmware on the board was built for {baud} baud: flash "
                            f"the one these board files build (esair flash "
                            f"{self.robot.name} --board central --port {self.port}), or "
                            f"set the central board's uart baud to {baud}")
                self.ser.baudrate = self.baud
                return None
        self.ser.baudrate = self.baud
        tried = ", ".join(str(b) for b in (self.baud,) + tuple(
            b for b in COMMON_BAUDS if b != self.baud))
        yield Check("reply", False, f"nothing answers 'v' (tried {tried} baud)",
                    "check that this is the robot's port, the cable (TX to RX, RX to TX, "
                    "GND joined; an RS-232 board needs its level shifter), the board's "
                    "power, and that ESAIR's firmware is on it (esair flash)")
        return None

    # -- whose firmware, which image ---------------------------------------------------
    def _identity(self, fields: dict[str, str]) -> Generator[Check, None, bool]:
        r = self.robot
        words = fields["_words"].split()
        want = {"servos": len(r.servos), "sensors": len(r.sensors), "motions": len(r.motions)}
        named = [w for w in words[1:] if "=" not in w]
        got = {k: fields.get(k) for k in want}
        if named or any(got[k] != str(v) for k, v in want.items()):
            seen = " ".join(f"{k}={v}" for k, v in got.items() if v is not None)
            who = f"as robot '{named[0]}'" if named else f"with {seen or fields['_words']}"
            yield Check("robot", False,
                        f"the board answers {who}, not as {r.name}'s central board "
                        f"({', '.join(f'{v} {k}' for k, v in want.items())})",
                        f"another robot's firmware, or another robot on this port: flash "
                        f"{r.name}'s (esair flash {r.name} --board central --port {self.port})")
            return False
        yield Check("robot", True, f"{r.name}'s central board: "
                                   f"{', '.join(f'{v} {k}' for k, v in want.items())}")
        from esair_min.codegen.buildid import central_build_id

        build = central_build_id(r)
        if fields.get("build") == build:
            yield Check("firmware", True, f"the build of these board files ({build})")
        else:
            yield Check("firmware", False,
                        f"build {fields.get('build', '(none)')}, not {build}, the build of "
                        f"these board files",
                        f"the board runs other firmware: esair flash {r.name} --board "
                        f"central --port {self.port}")
        return True

    def _image(self, fields: dict[str, str]) -> Iterator[Check]:
        if self.robot.eeprom is None:
            return
        want = header_of(build_image(self.robot)).crc
        write = f"esair eeprom {self.robot.name} --write {self.port}"
        if fields.get("image") != "ok":
            yield Check("motions", False, "the robot holds no valid motion image "
                                          "(image=bad)", f"write it: {write}")
        elif int(fields.get("crc", "-1"), 16) != want:
            yield Check("motions", False,
                        f"the robot's motion image (CRC {fields['crc']}) is not the one "
                        f"these board files build (CRC {want:04X})", f"write it: {write}")
        else:
            yield Check("motions", True, f"the image of these board files (CRC {want:04X})")

    # -- the bus and the sensors -------------------------------------------------------
    def _i2c(self) -> Iterator[Check]:
        i2c = self.robot.central.i2c
        if i2c is None or not i2c.devices:
            return
        if "i2c_scan" not in self.prefix:
            yield Check("i2c", False, "the board files declare no i2c_scan command",
                        "add the 'i' command (docs/protocol.md) to check the bus")
            return
        reply = self.link.ask(self.prefix["i2c_scan"])
        if reply is None or not reply.startswith("OK"):
            yield Check("i2c", False, f"the bus scan got {reply!r}",
                        "SCL or SDA may be held low: check the wiring and the pull-ups")
            return
        seen = {int(w, 16) for w in reply[2:].split()}
        for dev in i2c.devices:
            what = f"{dev.kind} '{dev.name}' at 0x{dev.address:02X}"
            if dev.address in seen:
                yield Check("i2c", True, f"{what} answers")
            else:
                yield Check("i2c", False, f"{what} does not answer",
                            "check its power, its SDA/SCL wires, the pull-ups (one pair of "
                            f"about 4.7 kOhm to the logic supply) and its address "
                            f"(the board file says 0x{dev.address:02X})")
        extra = seen - {d.address for d in i2c.devices}
        if extra:
            yield Check("i2c", True, "also answering, not in the board files: "
                                     + " ".join(f"0x{a:02X}" for a in sorted(extra)))

    def _sensors(self) -> Iterator[Check]:
        sensors = self.robot.sensors
        if not sensors or "sensors" not in self.prefix:
            return
        reply = self.link.ask(self.prefix["sensors"])
        if reply is None or not reply.startswith("OK "):
            yield Check("sensors", False, f"'s' got {reply!r}",
                        "the sensor board does not answer: see the i2c lines above")
            return
        try:
            values = [int(v) for v in reply[3:].split(",")]
        except ValueError:
            yield Check("sensors", False, f"'s' got {reply!r}", "")
            return
        bad = [f"{s.name}={v} (range {s.min}..{s.max})"
               for s, v in zip(sensors, values) if not s.min <= v <= s.max]
        if len(values) != len(sensors):
            yield Check("sensors", False, f"{len(values)} readings, {len(sensors)} sensors "
                                          "in the board files", "")
        elif bad:
            yield Check("sensors", False, "outside their range: " + ", ".join(bad),
                        "check each sensor's wiring and the mux's select lines")
        else:
            yield Check("sensors", True, f"{len(values)} readings inside their ranges")

    # -- the servos, with --move -------------------------------------------------------
    def _move(self, on_move: Callable[[str], None] | None) -> Iterator[Check]:
        if "motor" not in self.prefix:
            return
        o = self.prefix["motor"]
        timer = self.robot.central.timer2
        tick_s = timer.period_s if timer is not None else 0.02
        for i, s in enumerate(self.robot.servos):
            letter = chr(ord("a") + i)
            speed = chr(ord("a") + MOVE_SPEED)
            angles = [min(s.max_angle, s.stand_angle + MOVE_DEGREES),
                      max(s.min_angle, s.stand_angle - MOVE_DEGREES), s.stand_angle]
            failed = None
            for a in angles:
                if on_move is not None:
                    on_move(f"moving {s.name} to {a} degrees")
                reply = self.link.ask(f"{o}{letter}{speed}{a:03d}")
                if reply != "OK":
                    failed = f"{o}{letter}{speed}{a:03d} got {reply!r}"
                    break
                # at MOVE_SPEED degrees a tick the servo needs this long to get there
                time.sleep(MOVE_DEGREES * 2 / MOVE_SPEED * tick_s)
            if failed:
                yield Check("move", False, f"{s.name}: {failed}",
                            "the actuator board does not take the command: see the i2c lines")
            else:
                yield Check("move", True, f"{s.name} moved to {angles[0]}, {angles[1]} and "
                                          f"back to {s.stand_angle} degrees")
