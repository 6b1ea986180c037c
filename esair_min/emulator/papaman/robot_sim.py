"""The whole emulated robot: central, actuator and sensor boards on one virtual I2C bus.

The central board runs :class:`~esair_min.core.central.CentralCore` over emulated peripherals:

- its UART (:mod:`..uart`) at line rate, with the 64-byte receive ring;
- the I2C master on a :class:`~..i2c.TimedBus` (bus time at the declared speed, NACKs)
  to the 24LC256 holding the generated motion image, the actuator board's register map
  and the sensor board's register map;
- Timer2, ticking at the computed period (``robot.central.timer2.period_s``): each tick
  runs the core's ``tick()``, then drops the sync pin (the actuator board latches its
  registers and steps its servos), as the PIC port does after the tick's writes.

The superloop feeds received bytes to the core whenever it is ready and the CPU is not
busy on the bus: a byte that arrives during an I2C transfer is handled when it ends.
A reply that does not fit in the UART's transmit ring keeps the superloop waiting for
room (as on the PIC), and that counts as busy too: input that comes faster than its
replies can leave overruns the receive ring, as on the board.
Everything happens on a :class:`~..clock.VirtualClock`, so a run is deterministic.
"""

from __future__ import annotations

import functools
import random
import re
from collections import deque
from pathlib import Path
from typing import Callable

from esair_min.model import hardware
from esair_min.core.i2c_bus import Bus
from esair_min.core.central import CentralCore
from esair_min.core.protocol import TX_RING_TABLE
from esair_min.core.devices import Eeprom24, RegisterSlave, SimpleBus
from esair_min.errors import EsairError
from esair_min.core.image import build_image
from esair_min.model.identity import check_instance
from esair_min.model.robot import Robot
from esair_min.core.trace import TraceWriter, TracingBus
from esair_min.emulator.papaman.actuator import ActuatorBoard, stand_registers
from esair_min.emulator.clock import NS_PER_S, VirtualClock, seconds_to_ns
from esair_min.codegen.buildid import central_build_id
from esair_min.emulator.eeprom_chip import CyclingEeprom, attach_file
from esair_min.emulator.faults import Faults, corrupt
from esair_min.emulator.i2c import TimedBus
from esair_min.emulator.line import SerialHost
from esair_min.model.mcu import bus_overhead_ns, cycles_per_second
from esair_min.emulator.papaman.scenario import Scenario, load_scenario, quiet, resolve_scenario
from esair_min.emulator.transcript import Transcript
from esair_min.emulator.uart import GAP, RX_BYTE, RX_HOLD, RX_TAKE, Uart

HISTORY = 20     # lines kept in each of the state views
_EOL = re.compile(rb"\r\n|\r|\n")


class _MarkingBus:
    """Writes an ``@ <us>`` trace mark (when time moved) before each transaction."""

    def __init__(self, inner: TracingBus, mark: Callable[[], None]):
        self.inner = inner
        self._mark = mark

    def write(self, addr: int, data: bytes) -> bool:
        self._mark()
        return self.inner.write(addr, data)

    def write_read(self, addr: int, wdata: bytes, n: int) -> bytes | None:
        self._mark()
        return self.inner.write_read(addr, wdata, n)


class _Lines:
    """Splits a byte stream into lines (CR, LF or CRLF) and keeps the last few."""

    def __init__(self, keep: int):
        self.last: deque[str] = deque(maxlen=keep)
        self._buf = bytearray()
        self._cr = False
        self.count = 0

    def feed(self, data: bytes) -> list[str]:
        if (not self._buf and not self._cr and data.endswith(b"\r\n")
                and data.count(b"\n") == 1 and data.count(b"\r") == 1):
            if len(data) == 2:                       # one whole line, as the board sends
                return []
            line = data[:-2].decode("latin-1")
            self.last.append(line)
            self.count += 1
            return [line]
        if self._cr and data[:1] == b"\n":          # CR LF split across two chunks
            data = data[1:]
            self._cr = False
        if not data:
            return []
        self._cr = data[-1] == 13
        parts = _EOL.split(data)
        self._buf += parts[0]
        if len(parts) == 1:
            del self._buf[200:]
            return []
        done = [bytes(self._buf)] + parts[1:-1]
        self._buf = bytearray(parts[-1][:200])
        out = [d.decode("latin-1") for d in done if d]
        self.last.extend(out)
        self.count += len(out)
        return out


class Emulator(SerialHost):
    """PAPA-MAN (or any validated robot) in virtual time.

    ``scenario`` is a :class:`Scenario`, a scenario file, or the name of one in the
    robot's ``scenarios/`` folder; None keeps every sensor at rest. ``trace`` receives
    the event trace (docs/trace-format.md) with ``@ <us>`` time marks. ``instance``
    (8 hex digits) is this boot's id in the ``v`` reply (``id=instance``).
    ``hold_scenario``: the scenario's steps do not start at boot; each
    :meth:`play_scenario` plays them from then on (the sensors read its ``idle`` values
    until the first).
    """

    def __init__(self, robot: Robot, scenario: Scenario | str | Path | None = None,
                 faults: Faults = Faults(), trace: TraceWriter | None = None,  # noqa: B008 (frozen)
                 eeprom_image: bytes | None = None, transcript: bool = False,
                 instance: str | None = None, hold_scenario: bool = False,
                 eeprom_file: Path | None = None):
        central = robot.central
        if central.uart is None or central.timer2 is None:
            raise EsairError("the central board needs uart: and tick: to be emulated")
        self.robot = robot
        self.faults = faults
        self.clock = VirtualClock()
        self.tick_s = central.timer2.period_s
        self._tick_ns_exact = central.timer2.period_s * NS_PER_S
        self._rng = random.Random(faults.seed)

        # -- the devices on the bus
        devices: list = []
        self.eeprom: Eeprom24 | None = None
        self.corrupted_at: int | None = None
        eep = robot.eeprom
        self.image = build_image(robot) if eep else b""
        if eep is not None:
            data = self.image if eeprom_image is None else eeprom_image
            self.eeprom = Eeprom24(eep.size_bytes, eep.address, eep.address_bytes, data,
                                   eep.page_bytes)
            if eeprom_file is not None:
                attach_file(self.eeprom, eeprom_file)
            if faults.corrupt_eeprom:
                self.corrupted_at = corrupt(self.eeprom.memory, len(data), self._rng)
            self.eeprom_bus = CyclingEeprom(self.eeprom, lambda: self.bus.cursor(),
                                            NS_PER_S / central.i2c.speed_hz)
            devices.append(self.eeprom_bus)
        act, sen = robot.peer("actuator"), robot.peer("sensor")
        self.actuator_slave = RegisterSlave(act.address, act.registers) if act else None
        self.actuator: ActuatorBoard | None = None
        if self.actuator_slave is not None:
            regs = stand_registers(robot.servos)
            self.actuator_slave.registers[:len(regs)] = regs
            self.actuator_slave.fault = faults.actuator_nack
            self.actuator = ActuatorBoard(robot.servos, self.actuator_slave.registers)
            devices.append(self.actuator_slave)
        self.sensor_slave = RegisterSlave(sen.address, sen.registers) if sen else None
        if self.sensor_slave is not None and not faults.sensor_absent:
            devices.append(self.sensor_slave)
        self.devices = SimpleBus(devices)

        stuck_cycles = hardware.I2C_TIMEOUT_CYCLES + hardware.I2C_BUS_CLEAR_CYCLES
        part, clock_hz = central.mcu.part, central.mcu.clock_hz
        self.bus = TimedBus(self.devices, central.i2c.speed_hz, lambda: self.clock.now,
                            stuck_ns=stuck_cycles * NS_PER_S // cycles_per_second(part, clock_hz),
                            overhead_ns=lambda nw, nr: bus_overhead_ns(part, clock_hz, nw, nr))
        self.bus.stuck = faults.bus_stuck
        self.trace = trace
        self._last_mark = -1
        core_bus: Bus = self.bus
        if trace is not None:
            core_bus = _MarkingBus(TracingBus(self.bus, trace), self._mark_cursor)

        # -- state views
        self.commands = _Lines(HISTORY)      # lines the host sent
        self.replies = _Lines(HISTORY)       # lines the board sent (notices included)
        self.errors: deque[str] = deque(maxlen=HISTORY)
        self.transcript: Transcript | None = None   # see keep_transcript()
        self.on_line: Callable[[str], None] | None = None
        self.on_tick: Callable[[], None] | None = None   # after each tick's sync edge

        # -- scenario
        sensors = robot.sensors
        if scenario is None:
            self.scenario = quiet(sensors)
        elif isinstance(scenario, Scenario):
            self.scenario = scenario
        else:
            path = resolve_scenario(str(scenario), robot.source)
            self.scenario = load_scenario(path, sensors)
        self.sensor_values: tuple[int, ...] = self.scenario.idle
        self._set_sensors(self.scenario.idle)
        self.scenario_plays = 0          # plays started (the one at boot included)
        if not hold_scenario:
            self.play_scenario()

        # -- the central board
        self.core = CentralCore(robot, core_bus, self._send,
                                None if instance is None else check_instance(instance),
                                central_build_id(robot))
        self.uart = Uart(self.clock, central.uart.baud, self._feed, tx_ring=TX_RING_TABLE,
                         rx_mode=self._rx_mode, direct=self._rx_core)
        self._trace_rx = trace is not None and trace.rx_lines
        if self._trace_rx:
            self.uart._direct = self._rx_traced
        self.ticks = 0
        self._feed_pending = False
        self.clock.schedule(self._tick_time(1), self._tick)
        if faults.noise_per_s > 0:
            self._schedule_noise()
        if transcript:                  # before boot: its !READY is the first row
            self.keep_transcript()
        self.core.boot()

    # -- time ----------------------------------------------------------------------------
    @property
    def now_s(self) -> float:
        return self.clock.now / NS_PER_S

    def _tick_time(self, k: int) -> int:
        return int(round(k * self._tick_ns_exact))

    def run_for(self, seconds: float) -> None:
        """Advance virtual time by ``seconds`` (deterministic, as fast as the host can)."""
        self.clock.run_until(self.clock.now + seconds_to_ns(seconds))

    # -- the host side of the serial line (write, read, settle, next_event_ns: SerialHost)
    def _host_wrote(self, data: bytes) -> None:
        self.commands.feed(data)

    @property
    def idle(self) -> bool:
        """No byte on the line either way, none waiting in the ring, no write held."""
        return self.uart.rx_idle and self.uart.tx_idle and self.core.ready()

    def command(self, line: str | bytes, timeout_s: float = 2.0) -> list[str]:
        """Send one line (CR LF added) and run until its reply reached the host.

        Returns every line received meanwhile (notices included), the reply last;
        stops after ``timeout_s`` of virtual time without a reply.
        """
        return self.exchange(line, timeout_s)

    # -- faults at run time --------------------------------------------------------------
    def set_fault(self, device: str, on: bool) -> None:
        """``actuator``, ``sensor`` or ``eeprom`` stops (on) or starts acknowledging;
        ``bus``: SCL is held low (on) or released."""
        if device == "bus":
            self.bus.stuck = on
            return
        dev = {"actuator": self.actuator_slave, "sensor": self.sensor_slave,
               "eeprom": self.eeprom}.get(device)
        if dev is None:
            raise EsairError(f"no device '{device}' to fault (actuator, sensor, eeprom "
                             "or bus)")
        dev.fault = on

    # -- state views ---------------------------------------------------------------------
    @property
    def servo_angles(self) -> list[int]:
        return self.actuator.angles if self.actuator else []

    @property
    def servo_targets(self) -> list[int]:
        """Targets latched by the actuator board (at the sync edge after the write)."""
        return self.actuator.targets if self.actuator else []

    @property
    def playing(self) -> int | None:
        return self.core.playing

    # -- internals -----------------------------------------------------------------------
    def _mark(self, t_ns: int) -> None:
        us = t_ns // 1000
        if us != self._last_mark and self.trace is not None:
            self._last_mark = us
            self.trace.mark(us)

    def _mark_cursor(self) -> None:
        self._mark(self.bus.cursor())

    def play_scenario(self) -> None:
        """Play the scenario's steps from now on (``at_ms`` counted from now). The steps of
        an earlier play still to come are dropped: one play at a time."""
        self.scenario_plays += 1
        for at_ms, values in self.scenario.steps:
            self.clock.schedule(self.clock.now + at_ms * 1_000_000,
                                functools.partial(self._play_step, self.scenario_plays, values))

    def _play_step(self, play: int, values: tuple[int, ...]) -> None:
        if play == self.scenario_plays:
            self._set_sensors(values)

    def _set_sensors(self, values: tuple[int, ...]) -> None:
        self.sensor_values = values
        if self.sensor_slave is not None:
            self.sensor_slave.set_readings(values)

    def _send(self, data: bytes) -> None:
        at = self.bus.cursor()
        if self.trace is not None:
            self._mark(at)
            self.trace.tx(data)
        self.bus.hold(self.uart.board_send(data, at))   # the superloop waits for room
        tr = self.transcript
        for line in self.replies.feed(data):
            if tr is not None:
                tr.board_line(line)
            if line.startswith("E") or line.startswith("!E"):
                self.errors.append(line)
            if self.on_line is not None:
                self.on_line(line)

    def _tick(self) -> None:
        k = self.ticks + 1
        self.ticks = k
        self.clock.schedule(self._tick_time(k + 1), self._tick)
        if self.trace is not None:
            self._mark_cursor()
            self.trace.tick(k)
        self.core.tick()
        if self.actuator is not None:
            self.actuator.sync()        # the falling edge, after the tick's writes
        if self.on_tick is not None:
            self.on_tick()
        self._feed()

    def _rx_mode(self) -> int:
        """What the superloop would do with a byte arriving now (see :mod:`..uart`)."""
        if not self.core.ready():
            return RX_HOLD                  # until the tick sends the held write
        if self.bus.busy_until > self.clock.now:
            return RX_HOLD if self._feed_pending else RX_BYTE
        return RX_TAKE

    def _rx_core(self, data: bytes) -> None:
        """A run of bytes straight to the decoder (the UART's fast path)."""
        self.core.rx_run(data)

    def _rx_direct(self, data: bytes) -> None:
        """A run of bytes straight to the decoder (the UART's fast path), recorded."""
        self.transcript.rx(data)           # type: ignore[union-attr]
        if self._trace_rx:
            self._rx_traced(data)
        else:
            self.core.rx_run(data)

    def _rx_traced(self, data: bytes) -> None:
        """The UART's fast path with ``RX`` trace lines (``--trace-rx``): each line
        traced before it is decoded (before its reply)."""
        start = 0
        while start < len(data):
            ends = [i for i in (data.find(b"\r", start), data.find(b"\n", start)) if i >= 0]
            end = min(ends) + 1 if ends else len(data)
            self._rx_trace(data[start:end])
            self.core.rx_run(data[start:end])
            start = end

    def _rx_trace(self, data: bytes) -> None:
        self._mark(self.clock.now)
        self.trace.rx(data)                # type: ignore[union-attr]

    def keep_transcript(self) -> Transcript:
        """Record each line the decoder receives with its reply, and the notices
        (``transcript.rows``), from now on (``Emulator(..., transcript=True)``: from
        reset). For a display; it costs about a tenth of the emulator's speed, so it
        is off unless asked for."""
        if self.transcript is None:
            self.transcript = Transcript(2 * HISTORY, GAP)
            self.uart._direct = self._rx_direct
        return self.transcript

    def _feed_event(self) -> None:
        self._feed_pending = False
        self._feed()

    def _feed(self) -> None:
        """The superloop: feed the decoder while it is ready and the bus is free."""
        ring = self.uart.ring
        if not ring:
            return
        core, clock, bus = self.core, self.clock, self.bus
        ready, feed = core.ready, core.rx_byte
        tr = self.transcript
        got: list[int] = []                 # for the transcript, handed over in one go
        keep = got.append if tr is not None else None
        try:
            while ring and ready():
                if bus.busy_until > clock.now:
                    if not self._feed_pending:
                        self._feed_pending = True
                        clock.schedule(bus.busy_until, self._feed_event)
                    return
                b = ring.popleft()
                if keep is not None:
                    keep(b)
                if b & GAP:                 # bytes were lost right before this one
                    core.rx_overrun()
                if self._trace_rx:          # before the byte: its line's RX before its reply
                    self._rx_trace(bytes((b & 0xFF,)))
                feed(b & 0xFF)
        finally:
            if tr is not None:
                tr.rx_ring(got)

    def _schedule_noise(self) -> None:
        gap = self._rng.expovariate(self.faults.noise_per_s)
        self.clock.after(max(1, seconds_to_ns(gap)), self._noise)

    def _noise(self) -> None:
        self.uart.receive(self._rng.randrange(256))
        self._feed()
        self._schedule_noise()

    def close(self) -> None:
        if self.trace is not None:
            self.trace.close()
