"""The bus decoder and the register-log reader of the gpsim harness
(esair_min/pic/gpsim_wave.py), on waveforms and logs written by hand: no gpsim needed."""

from __future__ import annotations

from esair_min.pic.gpsim_wave import decode_i2c, read_register_log


class Wave:
    """SCL and SDA as (cycle, level) edge lists, one edge every 10 cycles, drawn the way
    gpsim's MSSP master draws them."""

    def __init__(self) -> None:
        self.scl: list[tuple[int, int]] = [(0, 1)]
        self.sda: list[tuple[int, int]] = [(0, 1)]
        self.t = 100

    def edge(self, pin: list[tuple[int, int]], level: int) -> None:
        self.t += 10
        pin.append((self.t, level))

    def start(self) -> None:
        self.edge(self.sda, 0)
        self.edge(self.scl, 0)

    def byte(self, value: int, ack: bool, bits: int = 9) -> None:
        """8 data bits and the ACK bit (or the first ``bits`` of them)."""
        for bit in ([(value >> (7 - i)) & 1 for i in range(8)] + [0 if ack else 1])[:bits]:
            self.edge(self.sda, bit)
            self.edge(self.scl, 1)
            self.edge(self.scl, 0)

    def stop(self) -> None:
        self.edge(self.sda, 0)
        self.edge(self.scl, 1)
        self.edge(self.sda, 1)


def test_decode_i2c_write_then_read_with_gpsim_repeated_start():
    # W 50 [01], repeated START drawn as gpsim 0.31 does (SDA low, SCL high, SDA high,
    # SCL low, SCL high, SDA low), R 50 one byte A5, master NACK, STOP.
    w = Wave()
    w.start()
    w.byte(0xA0, True)
    w.byte(0x01, True)
    w.stop()                      # looks like a STOP ...
    w.edge(w.scl, 0)              # ... but SCL falls again: a repeated START follows
    w.edge(w.scl, 1)
    w.edge(w.sda, 0)
    w.edge(w.scl, 0)
    w.byte(0xA1, True)
    w.byte(0xA5, False)
    w.stop()
    transfers = decode_i2c(w.scl, w.sda)
    assert [x.trace_line() for x in transfers] == ["R 50 01 1 A5"]
    assert transfers[0].stop == w.t


def test_a_hold_cuts_the_open_transfer_and_its_edges_are_not_decoded():
    """W 10 [01 02], cut by a hold after one data bit; inside the hold the master's
    blind clocking and a refused START; after it a new write W 10 [03]."""
    w = Wave()
    w.start()
    w.byte(0x20, True)
    w.byte(0x01, True)
    w.byte(0x02, True, bits=1)
    hold_from = w.t + 1
    w.edge(w.scl, 1)
    w.edge(w.scl, 0)                               # the pull-up at 0 V
    w.edge(w.sda, 1)
    w.edge(w.sda, 0)                               # a START attempt, refused
    hold_to = w.t + 5
    w.edge(w.scl, 1)                               # released
    w.edge(w.sda, 1)
    w.start()
    w.byte(0x20, True)
    w.byte(0x03, True)
    w.stop()
    plain = decode_i2c(w.scl, w.sda)
    assert not any(x.cut for x in plain)           # without the hold: a STOP at the release
    cut, whole = decode_i2c(w.scl, w.sda, ((hold_from, hold_to),))
    assert (cut.cut, cut.stop, cut.trace_line()) == (True, None, "W 10 01 NACK")
    assert (whole.cut, whole.trace_line()) == (False, "W 10 03 ACK")


def test_register_log_lines_with_a_source_line_prefix(tmp_path):
    log = tmp_path / "r.log"
    log.write_text("968: 0x000000000019D012 p18f452 0x1EF2 0x9AC6 bcf\t_SSPCON1,5,0\n"
                   "994:   Wrote: 0x0008 to _SSPCON1(0x0FC6) was 0x0028\n"
                   "0x000000000019D013 p18f452 0x1EF4 0x8AC6 bsf\t_SSPCON1,5,0\n"
                   "996:   Wrote: 0x0028 to _SSPCON1(0x0FC6) was 0x0008\n"
                   "0x0000000000003C94 p18f452 0x01AC 0xC000 movff\t_RCREG,REG000\n"
                   "  Read: 0x000D from _RCREG(0x0FAE)\n")
    assert read_register_log(log, {"_SSPCON1"}) == [(0x19D012, "_SSPCON1", 0x08),
                                                    (0x19D013, "_SSPCON1", 0x28)]
    assert read_register_log(log, {"_RCREG"}, reads=True) == [(0x3C94, "_RCREG", 0x0D)]
