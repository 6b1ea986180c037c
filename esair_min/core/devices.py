"""Simple I2C peripherals behind a :class:`~esair_min.core.i2c_bus.Bus`, without timing.

Used by the harness and the tests, and wrapped by the emulator (which adds time).
Each device answers ``write(data)`` and ``write_read(wdata, n)``; a device whose
``fault`` flag is set does not acknowledge.
"""

from __future__ import annotations

from typing import Callable, Iterable, Protocol, Sequence

from esair_min.errors import ProtocolError


class Device(Protocol):
    address: int
    fault: bool

    def write(self, data: bytes) -> bool: ...

    def write_read(self, wdata: bytes, n: int) -> bytes | None: ...


def read_wrapping(memory: bytearray, p: int, n: int) -> tuple[bytes, int]:
    """``n`` bytes of ``memory`` from ``p`` on, wrapping at its end; and the next pointer."""
    size = len(memory)
    if p + n <= size:                                # no wrap: one slice
        return bytes(memory[p:p + n]), (p + n) % size
    out = bytearray(n)
    for i in range(n):
        out[i] = memory[p]
        p = (p + 1) % size
    return bytes(out), p


class Eeprom24:
    """A 24LC256-class EEPROM: a memory address (high byte first) then data.

    Reads are sequential from the address and wrap at ``size``; writes store their
    data from the address on (random-address writes, wrapping at ``size``)."""

    def __init__(self, size: int, address: int, address_bytes: int = 2,
                 data: bytes = b"", page: int = 0):
        if len(data) > size:
            raise ProtocolError(f"{len(data)} bytes do not fit a {size}-byte EEPROM")
        self.size = size
        #: page write size (a power of two): a write wraps inside its page; 0: no pages
        self.page = page
        #: called with (offset, bytes) after each stored write (a file behind the chip)
        self.on_store: Callable[[int, bytes], None] | None = None
        self.address = address
        self.address_bytes = address_bytes
        self.memory = bytearray(b"\xff" * size)
        self.memory[:len(data)] = data
        self.pointer = 0
        self.fault = False

    def load(self, data: bytes) -> None:
        """Replace the whole contents (blank bytes 0xFF after ``data``)."""
        if len(data) > self.size:
            raise ProtocolError(f"{len(data)} bytes do not fit a {self.size}-byte EEPROM")
        self.memory[:] = b"\xff" * self.size
        self.memory[:len(data)] = data

    def poke(self, offset: int, value: int) -> None:
        if not 0 <= offset < self.size or not 0 <= value <= 255:
            raise ProtocolError(f"poke {offset:#x} {value:#x} is outside the "
                                f"{self.size}-byte EEPROM or a byte")
        self.memory[offset] = value

    def _set_pointer(self, wdata: bytes) -> bytes:
        k = self.address_bytes
        if len(wdata) >= k:
            self.pointer = int.from_bytes(wdata[:k], "big") % self.size
            return wdata[k:]
        return b""

    def write(self, data: bytes) -> bool:
        if self.fault:
            return False
        payload = self._set_pointer(data)
        page = self.page
        start = self.pointer
        store = self.on_store
        if page and start % page + len(payload) <= page:    # one page, no wrap: a slice
            self.memory[start:start + len(payload)] = payload
            self.pointer = start - start % page + (start + len(payload)) % page
            if payload and store is not None:
                store(start, bytes(payload))
            return True
        for b in payload:
            p = self.pointer
            self.memory[p] = b
            self.pointer = (p - p % page + (p + 1) % page) if page else (p + 1) % self.size
            if store is not None:
                store(p, bytes((b,)))
        return True

    def write_read(self, wdata: bytes, n: int) -> bytes | None:
        if self.fault:
            return None
        self._set_pointer(wdata)
        data, self.pointer = read_wrapping(self.memory, self.pointer, n)
        return data


class RegisterSlave:
    """A peer board as a register map: the first byte written is the register pointer,
    data follow with auto-increment (wrapping at the map's size)."""

    def __init__(self, address: int, n_registers: int):
        self.address = address
        self.registers = bytearray(n_registers)
        self.pointer = 0
        self.fault = False

    def write(self, data: bytes) -> bool:
        if self.fault:
            return False
        if data:
            n = len(self.registers)
            p = data[0] % n
            k = len(data) - 1
            if p + k <= n:                           # no wrap: one slice
                self.registers[p:p + k] = data[1:]
                self.pointer = (p + k) % n
                return True
            for b in data[1:]:
                self.registers[p] = b
                p = (p + 1) % n
            self.pointer = p
        return True

    def write_read(self, wdata: bytes, n: int) -> bytes | None:
        if self.fault:
            return None
        p = wdata[0] % len(self.registers) if wdata else self.pointer
        data, self.pointer = read_wrapping(self.registers, p, n)
        return data

    def set_readings(self, values: Sequence[int]) -> None:
        """Sensor board: store 10-bit readings as (low, high) register pairs."""
        if 2 * len(values) > len(self.registers):
            raise ProtocolError(f"{len(values)} readings for {len(self.registers) // 2} "
                                f"sensors")
        for i, v in enumerate(values):
            if not 0 <= v <= 1023:
                raise ProtocolError(f"reading {v} is not a 10-bit value")
            self.registers[2 * i] = v & 0xFF
            self.registers[2 * i + 1] = v >> 8

    def pairs(self) -> tuple[tuple[int, int], ...]:
        """Actuator board: the (low, high) pair of every servo."""
        r = self.registers
        return tuple((r[i], r[i + 1]) for i in range(0, len(r) - 1, 2))


class SimpleBus:
    """A bus dispatching by 7-bit address; an absent or faulty device does not ACK."""

    def __init__(self, devices: Iterable[Device]):
        self.devices = {d.address: d for d in devices}

    def write(self, addr: int, data: bytes) -> bool:
        d = self.devices.get(addr)
        return d is not None and d.write(data)

    def write_read(self, addr: int, wdata: bytes, n: int) -> bytes | None:
        d = self.devices.get(addr)
        return None if d is None else d.write_read(wdata, n)


class NullBus:
    """Acknowledges every write; reads return zeros (for benchmarks)."""

    def write(self, addr: int, data: bytes) -> bool:
        return True

    def write_read(self, addr: int, wdata: bytes, n: int) -> bytes | None:
        return bytes(n)
