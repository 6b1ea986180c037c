"""Boundary stimulus scripts for PAPA-MAN with their expected events, written from the
YAML and docs/protocol.md alone (never from a run of either core).

Each case is a stimulus script (docs/trace-format.md) and the events it must produce:
every UART line the board sends (its text, without CR LF) and every write to the
actuator board (``W <hex>``: register, then the bytes), in order; with ``ticks`` also
the ``T n`` lines. tests/min/test_boundaries.py runs them on the Python core and
tests/min/test_boundaries_c.py on the host-built C core: both must give these events
exactly, so a wrong boundary made in both cores at once still fails (the differential
tests, which only compare the two cores, would not see it).
"""

from __future__ import annotations

import re

from dataclasses import dataclass, field
from pathlib import Path

from esair_min.core.protocol import add_checksum
from esair_min.model.encoding import MAX_LINE, encode_pair
from esair_min.model.validate import load_robot

ROOT = Path(__file__).resolve().parents[2]
PAPAMAN = load_robot(ROOT / "boards" / "papaman")
SERVOS = PAPAMAN.servos
LIMITS = [(s.min_angle, s.max_angle) for s in SERVOS]
STAND = [s.stand_angle for s in SERVOS]
SPEED = [s.default_speed for s in SERVOS]
N = len(SERVOS)

OK = "OK"
E02 = "E02 line too long"
E03 = "E03 bad argument"
E04 = "E04 outside limits"
E12 = "E12 input overrun"
E13 = "E13 bad character"
N04 = "!E04 outside limits"
READY = "!READY esair-min/1 image=ok"
REACTION = PAPAMAN.central.reactions[0]
FIRED = f"!R {REACTION.name}"
RX_RING = 64            # the board's receive ring (docs/protocol.md)


@dataclass
class Case:
    name: str
    script: list[str] = field(default_factory=lambda: ["boot"])
    expected: list[str] = field(default_factory=lambda: [READY])
    ticks: bool = False          # keep the T lines in the events

    def rx(self, line: str, *replies: str) -> None:
        """Send ``line`` + CR; the replies it gets at once."""
        self.script.append("rx " + esc(line.encode("latin-1")) + "\\r")
        self.expected += replies

    def tick(self, *events: str) -> None:
        self.script.append("tick")
        self.expected += events

    @property
    def text(self) -> str:
        return "\n".join(self.script) + "\n"


def esc(data: bytes) -> str:
    """Bytes as an ``rx`` text (letters and digits kept, everything else ``\\xHH``)."""
    return "".join(chr(b) if chr(b).isalnum() and b < 0x80 else f"\\x{b:02X}" for b in data)


_IMAGE_ID = re.compile(r" crc=[0-9A-F]{4}| build=[0-9a-f]{8}")


def plain(text: str) -> str:
    """A !READY or v line without the image CRC and the build id (each board variant
    has its own; tests/min/test_core.py checks them)."""
    if text.startswith(("!READY ", "OK esair-min/")):
        return _IMAGE_ID.sub("", text)
    return text


def events(trace: list[str], ticks: bool = False) -> list[str]:
    """The UART lines (text) and actuator writes (``W hex``) of a trace, in order."""
    actuator = f"W {PAPAMAN.peer('actuator').address:02X} "
    out = []
    for line in trace:
        if line.startswith("TX "):
            out.append(plain(bytes.fromhex(line[3:]).decode("latin-1").removesuffix("\r\n")))
        elif line.startswith(actuator):
            assert line.endswith(" ACK"), line
            out.append("W " + line[len(actuator):-4])
        elif ticks and line.startswith("T "):
            out.append(line)
    return out


def pair(angle: int, speed: int) -> str:
    """A servo's register pair in hex: angle % 100, angle / 100 + 10 * speed."""
    low, high = encode_pair(angle, speed)
    return f"{low:02X}{high:02X}"


def burst(angles: list[int], speeds: list[int] = SPEED) -> str:
    """The write of every servo's pair from register 0."""
    return "W 00" + "".join(pair(a, s) for a, s in zip(angles, speeds))


def letter(i: int) -> str:
    return chr(ord("a") + i)


# -- commands that move servos ----------------------------------------------------------

def motor_case() -> Case:
    """``o``: every servo at its lower and upper limit (written) and one degree beyond
    each (E04, nothing held: the tick after writes nothing)."""
    c = Case("motor limits")
    for i, (lo, hi) in enumerate(LIMITS):
        for angle in (lo, hi):
            c.rx(f"o{letter(i)}c{angle:03d}")          # speed c = 2
            c.tick(f"W {2 * i:02X}{pair(angle, 2)}", OK)
        for angle in (lo - 1, hi + 1):
            if angle >= 0:                              # no 3-digit line asks for -1
                c.rx(f"o{letter(i)}c{angle:03d}", E04)
        c.tick()
    return c


def angle_code(angle: int) -> str:
    return chr(0x30 + angle // 3)


def angles_case() -> Case:
    """``c``: for every servo, each 3-degree code from 6 degrees below its lower limit to
    6 above its upper one (0..180): inside the limits written with the others kept,
    outside E04. PAPA-MAN's limits put a code exactly on a limit (60, 120, 0, 150,
    30, 180) and exactly one degree beyond one (39 < 40, 141 > 140)."""
    c = Case("angles limits")
    targets = list(STAND)
    for i, (lo, hi) in enumerate(LIMITS):
        near = [a for a in range(0, 181, 3) if lo - 6 <= a <= lo + 6 or hi - 6 <= a <= hi + 6]
        for angle in near:
            line = "c" + "." * i + angle_code(angle) + "." * (N - 1 - i)
            if lo <= angle <= hi:
                targets[i] = angle
                c.rx(line)
                c.tick(burst(targets), OK)
            else:
                c.rx(line, E04)
                c.tick()
    return c


def stand_case() -> Case:
    """``t`` after ``c`` moved every servo to its highest 3-degree angle: back to the
    stand angles, with the speeds set by ``a`` at their top (25) and bottom (0)."""
    c = Case("stand")
    top = [hi // 3 * 3 for _, hi in LIMITS]
    c.rx("c" + "".join(angle_code(a) for a in top))
    c.tick(burst(top), OK)
    c.rx("a" + "025" * N, OK)
    c.rx("t")
    c.tick(burst(STAND, [25] * N), OK)
    c.rx("a" + "000" * N, OK)
    c.rx("t")
    c.tick(burst(STAND, [0] * N), OK)
    return c


def frame_slot():
    """PAPA-MAN's one-frame motion (``stand``, number 0): where its frame is stored."""
    slot = next(s for s in PAPAMAN.layout.slots if s.frames == 1)
    motion = next(m for m in PAPAMAN.motions if m.number == slot.number)
    return slot, list(motion.frames[0].angles), list(motion.frames[0].speeds())


def poke_pair(offset: int, low: int, high: int) -> list[str]:
    return [f"poke {offset:X} {low:X}", f"poke {offset + 1:X} {high:X}"]


def frames_case() -> Case:
    """A stored frame (``PLYnn`` of a one-frame motion) whose pair for one servo is poked
    into the EEPROM after boot: at each limit written, one degree beyond E04 (notice,
    nothing written); a low byte of 99 is an angle, 100 never is."""
    c = Case("stored frame limits")
    slot, angles, speeds = frame_slot()
    play = f"PLY{slot.number:02d}"

    def frame(i: int, low: int, high: int, ok: bool) -> None:
        c.script.extend(poke_pair(slot.offset + 2 * i, low, high))
        c.rx(play, OK)
        if ok:
            row = [pair(a, s) for a, s in zip(angles, speeds)]
            row[i] = f"{low:02X}{high:02X}"
            c.tick("W 00" + "".join(row))
        else:
            c.tick(N04)

    for i, (lo, hi) in enumerate(LIMITS):
        s = speeds[i]
        for angle in (lo, hi):
            frame(i, *encode_pair(angle, s), True)
        for angle in (lo - 1, hi + 1):
            if angle >= 0:
                frame(i, *encode_pair(angle, s), False)
        c.script.extend(poke_pair(slot.offset + 2 * i, *encode_pair(angles[i], s)))
    knee = next(i for i, (lo, hi) in enumerate(LIMITS) if lo == 0 and hi >= 100)
    frame(knee, 99, 10 * speeds[knee], True)            # 99 degrees
    frame(knee, 100, 10 * speeds[knee], False)          # low byte 100: not a pair
    frame(knee, 0, 1 + 10 * speeds[knee], True)         # 100 degrees, the right way
    return c


# -- arguments --------------------------------------------------------------------------

def argument_case() -> Case:
    """The argument ranges: servo letters a..l, speed letters a..z, speeds 000..025,
    angle codes '0'..'l' (0..180), motion numbers of the table."""
    c = Case("argument ranges")
    last = letter(N - 1)
    c.rx(f"o{last}a090")
    c.tick(f"W {2 * (N - 1):02X}{pair(90, 0)}", OK)
    c.rx(f"o{last}z090")
    c.tick(f"W {2 * (N - 1):02X}{pair(90, 25)}", OK)
    for bad in (f"o{letter(N)}a090", "o`a090", "oa`090", "oa{090", "oaa-90", "oaa0:0"):
        c.rx(bad, E03)
    c.rx("a" + "025" * N, OK)
    c.rx("a" + "000" * (N - 1) + "026", E03)
    c.rx("a" + "026" + "000" * (N - 1), E03)
    c.rx("a" + "000" * N, OK)
    zero = next(i for i, (lo, _) in enumerate(LIMITS) if lo == 0)
    top = next(i for i, (_, hi) in enumerate(LIMITS) if hi == 180)
    moved = list(STAND)
    moved[zero], moved[top] = 0, 180
    line = ["."] * N
    line[zero], line[top] = "0", "l"
    c.rx("c" + "".join(line))
    c.tick(burst(moved, [0] * N), OK)
    for code in ("/", "m"):
        line[zero] = code
        c.rx("c" + "".join(line), E03)
    numbers = sorted(m.number for m in PAPAMAN.motions)
    c.rx(f"PLY{numbers[-1] + 1:02d}", "E08 no such motion")
    c.rx(f"PLY{numbers[-1]:02d}", OK)
    return c


def line_case() -> Case:
    """The 40-character line: the longest command with its checksum is exactly 40 and
    works; one character more is E02. A bad character is E13 up to the 40th byte and
    E02 (too long wins) past it."""
    c = Case("40-character line")
    longest = add_checksum("a" + "003" * N)
    assert len(longest) == MAX_LINE
    c.rx(longest, OK)
    c.rx(longest + "x", E02)
    c.rx("x" * MAX_LINE, E03)
    c.rx("x" * (MAX_LINE + 1), E02)
    c.rx("x" * (MAX_LINE - 1) + "\x01", E13)
    c.rx("x" * MAX_LINE + "\x01", E02)
    c.rx("x" * (MAX_LINE - 1) + "\x01" + "x", E02)
    c.rx("\x01" + "x" * (MAX_LINE - 1), E13)
    c.rx(add_checksum("x"), OK)
    return c


def checksum_case() -> Case:
    """The shortest line that can carry a checksum is the 3-character suffix alone."""
    c = Case("shortest checksum")
    c.rx("*00", "E01 unknown command")   # stripped: the empty command matches no row
    c.rx("x*7", E03)                      # two characters after x: no suffix
    c.rx("x*78", OK)
    return c


def ring_case(extra: int) -> Case:
    """The 64-byte receive ring: ``t`` holds the decoder until the tick while
    ``x`` CR lines fill the ring. 64 bytes all wait and are all answered; byte 65 is
    lost, and the line it belonged to is answered E12 (docs/protocol.md)."""
    c = Case(f"ring {RX_RING + extra}")
    c.script.append("rx t\\r")
    c.script.append("rx " + "x\\r" * (RX_RING // 2) + "x" * extra)
    c.script.append("tick")
    c.script.append("rx \\r")
    c.expected.append(burst(STAND))
    return c


# -- the balance reaction ---------------------------------------------------------------

def reaction_case(diff: int, polls: int = 3) -> Case:
    """Group sums that differ by ``diff`` (a minus b) on every poll: the reaction fires
    after ``samples`` polls only when ``|diff|`` is above the threshold."""
    c = Case(f"reaction diff {diff}", ticks=True)
    sensors = PAPAMAN.sensors
    a = [i for i, s in enumerate(sensors) if s.group == REACTION.compare[0]]
    b = [i for i, s in enumerate(sensors) if s.group == REACTION.compare[1]]
    values = [100] * len(sensors)
    values[a[0] if diff > 0 else b[0]] += abs(diff)
    c.script.append("sensor " + " ".join(map(str, values)))
    n = REACTION.poll_ticks * polls
    c.script.append(f"tick {n}")
    c.expected += [f"T {t}" for t in range(1, n + 1)]
    if abs(diff) > REACTION.threshold and polls >= REACTION.samples:
        c.expected.append(FIRED)
    return c


def reaction_count_case() -> Case:
    """``samples - 1`` tipping polls, a level one, then tipping again: the count starts
    over, so it fires ``samples`` polls after the level one, not before."""
    c = Case("reaction count restarts", ticks=True)
    p, k = REACTION.poll_ticks, REACTION.samples
    tipping = "sensor " + " ".join(["1023"] * 4 + ["0"] * 4)
    level = "sensor " + " ".join(["500"] * 8)
    c.script += [tipping, f"tick {p * (k - 1)}", level, f"tick {p}", tipping,
                 f"tick {p * k}"]
    total = p * (2 * k)
    c.expected += [f"T {t}" for t in range(1, total + 1)] + [FIRED]
    return c


def all_cases() -> list[Case]:
    t = REACTION.threshold
    return [motor_case(), angles_case(), stand_case(), frames_case(), argument_case(),
            line_case(), checksum_case(),
            reaction_case(t + 1), reaction_case(-(t + 1)), reaction_case(t),
            reaction_case(-t), reaction_case(t - 1), reaction_case(t + 1, polls=2),
            reaction_count_case()]
