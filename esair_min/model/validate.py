"""Load a robot folder (or one board file) into a validated, frozen :class:`Robot`.

Order: each file is loaded (marks kept) and checked against the model; then the
rules that a single board must obey; then the rules across boards. Every broken rule
is collected, each pointing at the node to change, and raised together
(:class:`~esair_min.errors.ConfigErrors`, sorted by file:line:col; one error is raised
as itself). What makes later checks meaningless stops them: a file that cannot be read
(a YAML syntax error) or that does not fit the model is not checked further, and the
rules across boards run only when every file loaded; a rule stops at its first error
where its next checks depend on it, and goes on where they do not.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Callable, Iterable, NoReturn

from pydantic import ValidationError

from esair_min.model import hardware, mcu
from esair_min.errors import ConfigError, config_errors, file_mark
from esair_min.components import COMPONENTS, motion, omni_base
from esair_min.model.encoding import CHECKSUM_CHARS, MAX_LINE, encode_high
from esair_min.model.board import DEFAULT_COMMANDS, Board, BoardDevice, Command, EepromDevice
from esair_min.model.figure import LEG_JOINTS
from esair_min.model.robot import Robot, frame_bus_load
from esair_min.config.schema_errors import did_you_mean, schema_errors
from esair_min.config.yamlload import Document, load_yaml

BAUD_TOLERANCE = 0.02
TICK_TOLERANCE = 0.01

#: The sections of the board core each role may have; each device kind adds its own
#: section to the roles it names (esair_min.components).
CORE_SECTIONS = {
    "central": {"uart", "tick", "sync", "commands", "reactions"},
    "actuator": {"sync", "figure"},
    "sensor": set(),
    "drive": set(),
}
ROLE_SECTIONS = {role: sections | {c.section for c in COMPONENTS if role in c.roles}
                 for role, sections in CORE_SECTIONS.items()}
OPTIONAL_SECTIONS = {"uart", "tick", "sync", "commands", "reactions", "figure"} | {
    c.section for c in COMPONENTS}


def _an(word: str) -> str:
    return f"an {word}" if word[:1] in "aeiou" else f"a {word}"


class _Checker:
    """Rules for one robot: each board with the file it was loaded from. Broken rules
    are collected in :attr:`errors`."""

    def __init__(self, boards: list[Board], docs: list[Document]):
        self.boards = boards
        # By identity, not by name: two files may (wrongly) give the same board name.
        self.docs = {id(b): d for b, d in zip(boards, docs)}
        self.errors: list[ConfigError] = []
        #: a rule stopped at an error its next checks depend on (:meth:`fail`): the
        #: rules across boards, which take every board's own rules as kept, do not run
        self.stopped = False

    def doc(self, board: Board) -> Document:
        return self.docs[id(board)]

    def error(self, board: Board, loc: Iterable[Any], message: str, *,
              key: bool = False) -> ConfigError:
        return ConfigError(message, self.doc(board).mark(tuple(loc), key=key))

    def fail(self, board: Board, loc: Iterable[Any], message: str, *,
             key: bool = False) -> NoReturn:
        """A broken rule whose next checks depend on it: the rule stops here (and
        :meth:`rule` collects the error)."""
        raise self.error(board, loc, message, key=key)

    def report(self, board: Board, loc: Iterable[Any], message: str, *,
               key: bool = False) -> None:
        """A broken rule whose next checks do not depend on it: collected, and the
        rule goes on."""
        self.errors.append(self.error(board, loc, message, key=key))

    def rule(self, check: Callable[..., None], *args: Any) -> None:
        """Run one rule; its :meth:`fail` is collected and the next rule runs."""
        try:
            check(*args)
        except ConfigError as exc:
            self.errors.extend(exc.each())
            self.stopped = True

    # -- single board -------------------------------------------------------------
    def board_rules(self, b: Board) -> None:
        self.rule(self.section_rules, b)
        self.rule(self.i2c_rules, b)
        self.rule(self.clock_rules, b)
        for c in COMPONENTS:
            for field in c.unique if c.many else ():
                self.rule(self.unique, b, c.section, field)
        self.rule(self.unique, b, "reactions", "name")
        for c in COMPONENTS:
            self.rule(c.board_rules, self, b)
        self.rule(self.pin_rules, b)
        self.rule(self.figure_rules, b)

    def section_rules(self, b: Board) -> None:
        data = self.doc(b).data
        allowed = ROLE_SECTIONS[b.role]
        for section in data:
            if section in OPTIONAL_SECTIONS - allowed:
                self.report(b, (section,), f"'{section}' does not belong on {_an(b.role)} "
                            f"board ({_an(b.role)} board may have: "
                            f"{', '.join(sorted(allowed))}); remove it, or check "
                            f"'role: {b.role}'", key=True)
        required = {"central": ["uart", "tick"] + ([] if b.base else ["sync"]),
                    "actuator": ["sync", "servos"], "sensor": ["sensors"],
                    "drive": ["motors"]}[b.role]
        for section in required:
            if not getattr(b, section):
                if section in data:
                    self.report(b, (section,), f"'{section}' is empty, but {_an(b.role)} "
                                f"board needs it", key=True)
                else:
                    self.report(b, (), f"{_an(b.role)} board needs a '{section}:' section")

    def figure_rules(self, b: Board) -> None:
        """The figure names servos of this board, each joint its own servo."""
        f = b.figure
        if f is None:
            return
        names = [s.name for s in b.servos]
        for side in ("left", "right"):
            if side not in f.legs:
                self.report(b, ("figure", "legs"), f"figure: a biped needs a '{side}' leg")
        seen: dict[str, tuple[str, str]] = {}
        for side, leg in f.legs.items():
            for joint in LEG_JOINTS:
                servo = getattr(leg, joint)
                loc = ("figure", "legs", side, joint)
                if servo not in names:
                    self.report(b, loc, f"figure: {side} {joint}: no servo named '{servo}' on "
                              f"this board{did_you_mean(servo, names)}")
                if servo in seen:
                    self.report(b, loc, f"figure: {side} {joint}: servo '{servo}' already turns "
                              f"the {seen[servo][0]} {seen[servo][1]}")
                seen[servo] = (side, joint)
        for i, servo in enumerate(f.reversed):
            if servo not in seen:
                self.report(b, ("figure", "reversed", i), f"figure: reversed: '{servo}' turns no "
                          f"joint of the figure{did_you_mean(servo, list(seen))}")
        for servo in f.zero:
            if servo not in seen:
                self.report(b, ("figure", "zero", servo), f"figure: zero: '{servo}' turns no "
                          f"joint of the figure{did_you_mean(servo, list(seen))}", key=True)

    def unique(self, b: Board, section: str, field: str) -> None:
        seen: dict[Any, int] = {}
        for i, item in enumerate(getattr(b, section) or ()):
            value = getattr(item, field)
            if value is None:
                continue                 # an optional field not given (a sensor's channel)
            if value in seen:
                line = self.doc(b).mark((section, seen[value], field)).line
                self.report(b, (section, i, field),
                            f"{section[:-1]} {field} {value!r} is already used at line "
                            f"{line}; each {section[:-1]} needs its own {field}")
            else:
                seen[value] = i

    def i2c_rules(self, b: Board) -> None:
        i2c = b.i2c
        want = "master" if b.role == "central" else "slave"
        if i2c.mode != want:
            self.fail(b, ("i2c", "mode"), f"{_an(b.role)} board must be an I2C {want} "
                      f"(mode: {want})")
        if want == "slave":
            if i2c.address is None:
                self.report(b, ("i2c",), "an I2C slave needs its own 'address' (0x08..0x77)")
            if i2c.devices:
                self.report(b, ("i2c", "devices"), "an I2C slave has no 'devices' (only a "
                            "master talks to devices)", key=True)
            if i2c.speed_hz != hardware.SLAVE_SPEED_HZ:
                self.report(b, ("i2c", "speed_hz"), f"the generated I2C slave runs at "
                            f"{hardware.SLAVE_SPEED_HZ} Hz only (at {i2c.speed_hz} Hz a byte "
                            "it takes late could be mistaken for its address); use speed_hz: "
                            f"{hardware.SLAVE_SPEED_HZ} on every board")
            return
        if i2c.address is not None:
            self.report(b, ("i2c", "address"), "an I2C master has no own 'address'; remove "
                        "it", key=True)
        if b.i2c_setting is None:
            limit = ("TWBR must be 10..255" if b.spec.family == "avr"
                     else "SSPADD must be 1..127")
            self.report(b, ("i2c", "speed_hz"), f"I2C {i2c.speed_hz} Hz cannot be made at "
                        f"{b.mcu.clock_hz} Hz ({limit}); choose another "
                        "speed_hz or clock_hz")
        self.unique_devices(b)

    def unique_devices(self, b: Board) -> None:
        names: dict[str, int] = {}
        addrs: dict[int, int] = {}
        for i, dev in enumerate(b.i2c.devices):
            doc = self.doc(b)
            if dev.name in names:
                self.report(b, ("i2c", "devices", i, "name"), f"device name '{dev.name}' is "
                            f"already used at line "
                            f"{doc.mark(('i2c', 'devices', names[dev.name])).line}; "
                            "each device needs its own name")
            if dev.address in addrs:
                other = b.i2c.devices[addrs[dev.address]]
                line = doc.mark(("i2c", "devices", addrs[dev.address], "address")).line
                self.report(b, ("i2c", "devices", i, "address"),
                            f"I2C address 0x{dev.address:02X} of '{dev.name}' collides with "
                            f"'{other.name}' (line {line}); every device on the bus needs "
                            "its own address")
            names.setdefault(dev.name, i)
            addrs.setdefault(dev.address, i)
        if sum(isinstance(d, EepromDevice) for d in b.i2c.devices) > 1:
            self.report(b, ("i2c", "devices"), "only one EEPROM device is supported; remove "
                        "the others", key=True)

    def clock_rules(self, b: Board) -> None:
        part = mcu.MCUS[b.mcu.part]
        if b.mcu.package is not None and b.mcu.package not in part.packages:
            self.report(b, ("mcu", "package"), f"the {part.name} comes in no package "
                        f"'{b.mcu.package}'; use one of: {', '.join(part.packages)}")
        clock = b.mcu.clock_hz
        if clock > b.spec.max_clock_hz:
            self.report(b, ("mcu", "clock_hz"), f"the {b.spec.name} runs at most at "
                        f"{b.spec.max_clock_hz} Hz, not {clock}; use a slower clock_hz")
        if b.uart is not None:
            setting = b.baud
            assert setting is not None
            if abs(setting.error) > BAUD_TOLERANCE:
                self.report(b, ("uart", "baud"),
                            f"baud {b.uart.baud} cannot be made at {clock} Hz within 2 %: "
                            f"best is {setting.describe()} "
                            f"({setting.actual:.0f} baud, {setting.error_percent:+.2f} %)")
        if b.tick is not None:
            if not math.isfinite(b.tick.period_ms):
                self.fail(b, ("tick", "period_ms"), f"tick period must be a finite number "
                          f"of ms, not {b.tick.period_ms}")
            t2 = b.timer2
            assert t2 is not None
            want = b.tick.period_ms
            err = (t2.period_ms - want) / want
            if abs(err) > TICK_TOLERANCE:
                self.fail(b, ("tick", "period_ms"),
                          f"tick period {want:g} ms cannot be made by {b.spec.tick_timer} at "
                          f"{clock} Hz within 1 %: nearest is {t2.period_ms:.4f} ms "
                          f"({t2.fields()})")

    def pin_rules(self, b: Board) -> None:
        used: dict[str, str] = {}

        def claim(pin: str, what: str, loc: tuple[Any, ...]) -> None:
            if pin not in b.spec.pins and pin not in b.spec.adc_pins.values():
                self.report(b, loc, f"pin {pin} of {what} does not exist on the "
                            f"{b.mcu.part} ({b.spec.pin_help})")
            elif pin in used:
                self.report(b, loc, f"pin {pin} is used twice: by {used[pin]} and by "
                            f"{what}; give {what} another pin")
            else:
                used[pin] = what

        spec = b.spec
        if b.uart is not None:
            for pin in spec.uart_pins:
                claim(pin, "the UART", ("uart",))
        for pin in spec.i2c_pins:
            claim(pin, "I2C", ("i2c",))
        if b.sync is not None:
            claim(b.sync.pin, "the sync line", ("sync", "pin"))
            if b.role == "actuator" and b.sync.pin != spec.sync_input:
                self.report(b, ("sync", "pin"), f"the actuator's sync input must be "
                            f"{spec.sync_input} on the {spec.name} (the pin whose falling "
                            f"edge sets a flag the firmware polls), not {b.sync.pin}")
        for c in COMPONENTS:
            if c.section == "sensors":
                continue                 # a channel's pin depends on the MCU: below
            for i, item in enumerate(c.items(b)):
                for pin, what, loc in c.pins(item):
                    claim(pin, what, c.item_loc(i) + loc)
        adc = "ADC" if spec.family == "avr" else "AN"
        # The mux's common channel first: a sensor on the same channel is the one to move.
        inputs: list[tuple[str, int, tuple[Any, ...]]] = (
            [("the mux's common output", b.mux.channel, ("mux", "channel"))]
            if b.mux is not None else [])
        inputs += [(f"sensor '{s.name}'", s.channel, ("sensors", i, "channel"))
                   for i, s in enumerate(b.sensors) if s.channel is not None]
        channels = set()
        for what, channel, loc in inputs:
            if channel in channels and loc[0] == "sensors" and (b.mux is None
                                                                or channel != b.mux.channel):
                continue                 # a channel used twice: the 'unique' rule's error
            channels.add(channel)
            if channel not in spec.adc_pins:
                elsewhere = mcu.MCUS[b.mcu.part].packages_with_channel(channel)
                name = spec.name
                if elsewhere:
                    name += f" in the {spec.packages[spec.package]}"
                hint = (f"; ADC{channel} exists in the "
                        f"{' and the '.join(spec.packages[p] for p in elsewhere)} only: set "
                        f"mcu.package: {elsewhere[0]}, or use another channel" if elsewhere else "")
                self.report(b, loc, f"{what}: the {name} has no analog channel {channel}{hint}")
                continue
            claim(spec.adc_pins[channel], f"{what} ({adc}{channel})", loc)

    # -- across boards ------------------------------------------------------------
    def robot_rules(self) -> None:
        """The rules across boards. Two boards of one name or one role, or no central
        board, leave the others nothing to check against: they stop here."""
        before = len(self.errors)
        seen: dict[str, Board] = {}
        for b in self.boards:
            if b.board in seen:
                self.report(b, ("board",), f"two files describe board '{b.board}' "
                            f"(the other is {self.doc(seen[b.board]).path})")
            else:
                seen[b.board] = b
        by_role: dict[str, Board] = {}
        for b in self.boards:
            if b.role in by_role:
                other = by_role[b.role]
                self.report(b, ("role",), f"a robot has one {b.role} board, and board "
                            f"'{other.board}' ({self.doc(other).path}) already is one; "
                            "change one 'role'")
            else:
                by_role[b.role] = b
        central = by_role.get("central")
        if central is None:
            self.errors.append(ConfigError("no central board in this robot (one board needs "
                                           "'role: central')",
                                           file_mark(self.doc(self.boards[0]).path)))
        if central is None or len(self.errors) > before:
            return
        self.peer_rules(central, by_role)
        if self.stopped:    # no storage for the motions, a drive board without a base:
            return          # the command table and the motions are then not what was meant
        actuator = by_role.get("actuator")
        self.command_rules(central, len(actuator.servos) if actuator else 0, by_role)
        for c in COMPONENTS:
            self.rule(c.robot_rules, self, central, by_role)
        for i in range(len(central.reactions)):
            self.reaction_rules(central, i, by_role.get("sensor"))
        self.rule(self.bus_budget_rule, central, actuator, by_role.get("sensor"))

    def bus_budget_rule(self, central: Board, actuator: Board | None,
                        sensor: Board | None) -> None:
        """A motion plays a frame every delay_ticks ticks: the frame write, the read of
        the next frame and a sensor poll must fit in that time on the bus, with the
        PIC master's overhead (hardware.FIRMWARE_BUS_OVERHEAD)."""
        load = frame_bus_load(central, actuator, sensor)
        t2 = central.timer2
        if load is None or t2 is None:
            return
        motion = min(central.motions, key=lambda m: m.delay_ticks)
        speed = central.i2c.speed_hz
        need_s = load.seconds(speed) * hardware.FIRMWARE_BUS_OVERHEAD
        have_s = motion.delay_ticks * t2.period_s
        if need_s <= have_s:
            return
        ticks = math.ceil(need_s / t2.period_s)     # (the slaves allow no faster bus)
        poll = f" + sensor poll {load.poll}" if load.poll else ""
        self.fail(central, ("i2c", "speed_hz"),
                  f"I2C at {speed} Hz is too slow for motion '{motion.name}' (a frame every "
                  f"{'tick' if motion.delay_ticks == 1 else f'{motion.delay_ticks} ticks'}, "
                  f"{have_s * 1e3:.2f} ms): frame write {load.write} + next frame read "
                  f"{load.read}{poll} bit times = {load.seconds(speed) * 1e3:.2f} ms, "
                  f"{need_s * 1e3:.2f} ms with the PIC master's overhead; use "
                  f"delay_ticks: {ticks} for motion '{motion.name}' or a longer tick")

    def peer_rules(self, central: Board, by_role: dict[str, Board]) -> None:
        names = {b.board: b for b in self.boards}
        reached = set()
        misnamed = False
        for i, dev in enumerate(central.i2c.devices):
            if not isinstance(dev, BoardDevice):
                continue
            peer = names.get(dev.board)
            if peer is None or peer is central:
                self.report(central, ("i2c", "devices", i, "board"),
                            f"no peer board named '{dev.board}' in this robot"
                            f"{did_you_mean(dev.board, [n for n in names if n != central.board])}")
                misnamed = True
                continue
            reached.add(peer.board)
            self.peer_device_rules(central, i, dev, peer)
        for b in self.boards:     # (a misnamed device may be meant for it: that error only)
            if b.role != "central" and b.board not in reached and not misnamed:
                self.report(b, ("board",), f"board '{b.board}' is not among the central "
                            f"board's I2C devices, so nothing can reach it; add it there "
                            f"(kind: board, board: {b.board})")
        self.rule(motion.storage_rules, self, central, by_role)
        self.rule(omni_base.pairing_rules, self, central, by_role)

    def peer_device_rules(self, central: Board, i: int, dev: BoardDevice, peer: Board) -> None:
        """The central board's device entry ``i`` agrees with the board it names."""
        # (a slave without an address is its own board's error)
        if peer.i2c.address is not None and peer.i2c.address != dev.address:
            self.report(central, ("i2c", "devices", i, "address"),
                        f"device '{dev.name}' is at 0x{dev.address:02X} here but board "
                        f"'{peer.board}' answers at 0x{peer.i2c.address:02X} "
                        f"({self.doc(peer).mark(('i2c', 'address'))}); make the "
                        "two addresses agree")
        if peer.register_count != dev.registers:
            self.report(central, ("i2c", "devices", i, "registers"),
                        f"device '{dev.name}' declares {dev.registers} registers but board "
                        f"'{peer.board}' has {peer.register_count} "
                        f"(2 per servo and per sensor); set registers: {peer.register_count}")
        if peer.i2c.speed_hz != central.i2c.speed_hz:     # the peer's is the slaves' own
            self.report(central, ("i2c", "speed_hz"),
                        f"bus speed {central.i2c.speed_hz} Hz differs from the "
                        f"{peer.i2c.speed_hz} Hz of board '{peer.board}' "
                        f"({self.doc(peer).mark(('i2c', 'speed_hz'))}); use speed_hz: "
                        f"{peer.i2c.speed_hz}")

    def command_rules(self, central: Board, n: int, by_role: dict[str, Board]) -> None:
        commands = central.commands or ()
        loc_base = ("commands",)
        needs = {"stand": "actuator", "motor": "actuator", "speeds": "actuator",
                 "angles": "actuator", "sensors": "sensor"}
        for i, c in enumerate(commands):
            role = needs.get(c.action)
            if role is not None and role not in by_role:
                self.report(central, loc_base + (i, "action"), f"command '{c.name}' "
                            f"(action {c.action}) needs a {role} board in this robot")
            if (c.action == "play" or c.action.startswith("image_")) and \
                    central.device("eeprom") is None:
                self.report(central, loc_base + (i, "action"), f"command '{c.name}' "
                            f"(action {c.action}) needs an EEPROM among the I2C devices")
            for j in range(i):
                o = commands[j]
                if o.name == c.name:
                    self.report(central, loc_base + (i, "name"),
                                f"command name '{c.name}' is already used at line "
                                f"{self.doc(central).mark(loc_base + (j, 'name')).line}; "
                                "each command needs its own name")
                same = (o.length(n) == c.length(n) or (o.variable and c.length(n) >= o.length(n))
                        or (c.variable and o.length(n) >= c.length(n)))
                if same and (c.prefix.startswith(o.prefix) or o.prefix.startswith(c.prefix)):
                    self.report(central, loc_base + (i, "prefix"),
                                f"command '{c.name}' (prefix {c.prefix!r}, {c.length(n)}-char "
                                f"lines) is ambiguous with '{o.name}' (prefix {o.prefix!r}, "
                                f"{o.length(n)}-char lines): one line would match both; "
                                "change one prefix")
            if c.length(n) + CHECKSUM_CHARS > MAX_LINE:
                self.report(central, loc_base + (i, "prefix"),
                            f"command '{c.name}' lines are {c.length(n)} chars; with a "
                            f"{CHECKSUM_CHARS}-char checksum they exceed the {MAX_LINE}-char "
                            "line limit")
            if c.motion is not None:
                if c.action != "play":
                    self.report(central, loc_base + (i, "motion"),
                                "'motion' is only for action 'play'; remove it or use "
                                "action: play", key=True)
                if all(m.name != c.motion for m in central.motions):
                    self.report(central, loc_base + (i, "motion"),
                                f"no motion named '{c.motion}'"
                                f"{did_you_mean(c.motion, [m.name for m in central.motions])}")

    def reaction_rules(self, central: Board, i: int, sensor: Board | None) -> None:
        r = central.reactions[i]
        groups = sorted({s.group for s in sensor.sensors}) if sensor else []
        for k, g in enumerate(r.compare):
            if g not in groups:
                self.report(central, ("reactions", i, "compare", k),
                            f"reaction '{r.name}': no sensor group '{g}'"
                            f"{did_you_mean(g, groups)} (groups: {', '.join(groups) or 'none'})")
        if r.compare[0] == r.compare[1]:
            self.report(central, ("reactions", i, "compare", 1),
                        f"reaction '{r.name}' compares group '{r.compare[0]}' with itself; "
                        "compare two different groups")
        if all(m.name != r.motion for m in central.motions):
            self.report(central, ("reactions", i, "motion"), f"reaction '{r.name}': no motion "
                        f"named '{r.motion}'{did_you_mean(r.motion, [m.name for m in central.motions])}")


def _raise_all(errors: list[ConfigError]) -> None:
    err = config_errors(errors)
    if err is not None:
        raise err


def load_board(path: Path | str) -> tuple[Board, Document]:
    """One board file, checked against the model (single-board rules not yet applied).
    A file that cannot be read raises its one error; one that does not fit the model
    raises every misfit (one per node)."""
    doc = load_yaml(path)
    try:
        board = Board.model_validate(doc.data)
    except ValidationError as exc:
        _raise_all(schema_errors(exc, doc, Board))
        raise AssertionError("a ValidationError has errors") from None
    if board.role == "central" and board.commands is None:
        # An omni base's commands are fixed (docs/protocol.md, STARFISH): no table.
        board = board.model_copy(update={"commands": () if board.base else DEFAULT_COMMANDS})
    return board, doc


def check_board_alone(path: Path | str) -> Board:
    """One board file checked on its own: every rule that needs no other board."""
    board, doc = load_board(path)
    checker = _Checker([board], [doc])
    checker.board_rules(board)
    _raise_all(checker.errors)
    return board


def is_whole_robot(board: Board) -> bool:
    """A board file that is a robot by itself: a central board with no peer boards."""
    return board.role == "central" and board.device("board") is None


def board_files(path: Path | str) -> list[Path]:
    """The board files of a robot folder (``*.yaml``/``*.yml``, sorted), or ``[path]``."""
    p = Path(path)
    if p.is_dir():
        files = sorted(list(p.glob("*.yaml")) + list(p.glob("*.yml")))
        if not files:
            raise ConfigError("no board files (*.yaml) in this folder", file_mark(str(p)))
        return files
    return [p]


def load_robot(path: Path | str) -> Robot:
    """Load and validate every board of the robot at ``path`` (a folder or one file).

    Raises :class:`ConfigError` with every error found (module docstring)."""
    files = board_files(path)
    boards: list[Board] = []
    docs: list[Document] = []
    unread: list[ConfigError] = []
    for f in files:
        try:
            board, doc = load_board(f)
        except ConfigError as exc:
            unread.extend(exc.each())
            continue
        boards.append(board)
        docs.append(doc)
    checker = _Checker(boards, docs)
    for b in boards:
        checker.board_rules(b)
    p = Path(path)
    if not unread and not p.is_dir() and boards[0].role != "central":
        checker.errors.append(ConfigError(
            f"this {boards[0].role} board alone is not a robot, which needs its central "
            f"board too; give the folder that holds all its board files ({p.parent})",
            docs[0].mark(("role",))))
    elif not unread and not checker.stopped:
        checker.robot_rules()
    _raise_all(unread + checker.errors)
    name = p.name if p.is_dir() else p.stem
    return Robot(name, str(path), tuple(boards), tuple(str(f) for f in files))


__all__ = ["load_robot", "load_board", "check_board_alone", "is_whole_robot", "board_files", "encode_high",
           "MAX_LINE", "Command"]
