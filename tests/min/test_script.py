"""Stimulus scripts are read the same way by the Python harness and the host C port
(issue 10, item 2): every bad script gets the same clear error, word for word, on both
sides, after the same trace; lines of any length; raw control bytes refused; a script
that is not UTF-8 refused at the byte; the C Intel HEX loader checks what intelhex
checks. The C side runs plain and under ASan+UBSan (any report fails the test, since
stderr must be exactly the error line).
"""

from __future__ import annotations

from tests.support.board_lines import ready

import subprocess
from pathlib import Path

import pytest

from esair_min.core.stimulus import main as harness_main
from esair_min.core.image import build_image, write_hex

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
PAPAMAN = str(ROOT / "boards" / "papaman")
COMMANDS = ("(boot, rx TEXT, tick [N], sensor V..., fault DEVICE on|off, poke OFFSET BYTE, "
            "image PATH)")
NOT_TICKS = "is not a decimal number from 0 to 1000000"
UNKNOWN_ESCAPE = r"unknown escape (use \r \n \xHH \\)"


@pytest.fixture(scope="module")
def hosts(central_host):
    """The central board's host port, built plainly and with ASan+UBSan."""
    return [central_host["plain"], central_host["san"]]


def both(hosts, capsys, script: Path) -> tuple[int, str, str]:
    """Run the script on the Python harness and on both C builds; they must agree on
    the exit status, the trace and the error. Returns them."""
    status = harness_main([PAPAMAN, str(script)])
    py = capsys.readouterr()
    for binary in hosts:
        proc = subprocess.run([str(binary), str(script)], capture_output=True, timeout=60)
        c = (proc.returncode, proc.stdout.decode(), proc.stderr.decode("utf-8", "replace"))
        assert c == (status, py.out, py.err), binary.name
    return status, py.out, py.err


def check(hosts, capsys, tmp_path, script: bytes, message: str) -> str:
    """A bad script: exit 1 and exactly ``error: <message>`` (S is the script's path,
    D its folder) on both sides; the trace written before it."""
    path = tmp_path / "s.txt"
    path.write_bytes(script)
    status, out, err = both(hosts, capsys, path)
    expected = message.replace("S:", f"{path}:").replace("D/", f"{tmp_path}/")
    assert (status, err) == (1, f"error: {expected}\n")
    return out


# -- script text --------------------------------------------------------------------------

@pytest.mark.parametrize("script, message", [
    (b"boot\nfrobnicate\n", f"S:2:1: bad script line 'frobnicate' {COMMANDS}"),
    (b"boot\n  tick 1 2  # two\n", f"S:2:1: bad script line 'tick 1 2' {COMMANDS}"),
    (b"tick 1_0\n", f"S:1:1: tick count '1_0' {NOT_TICKS}"),
    (b"tick -1\n", f"S:1:1: tick count '-1' {NOT_TICKS}"),
    (b"tick +1\n", f"S:1:1: tick count '+1' {NOT_TICKS}"),
    (b"tick 0x10\n", f"S:1:1: tick count '0x10' {NOT_TICKS}"),
    (b"tick 1000001\n", f"S:1:1: tick count '1000001' {NOT_TICKS}"),
    (b"tick 99999999999999999999\n", f"S:1:1: tick count '99999999999999999999' {NOT_TICKS}"),
    ("tick \u0661\n".encode(), f"S:1:1: tick count '\u0661' {NOT_TICKS}"),   # Arabic-Indic 1
    (b"sensor 1 1024\n", "S:1:1: reading '1024' is not a decimal number from 0 to 1023"),
    (b"sensor 1 2 3 4 5 6 7 8 9\n", "S:1:1: 9 readings for 8 sensors"),
    (b"poke 8000 1\n", "S:1:1: poke offset '8000' is not a hex number from 0 to 7FFF"),
    (b"poke 10 100\n", "S:1:1: poke byte '100' is not a hex number from 0 to FF"),
    (b"fault motor on\n", "S:1:1: no device 'motor' (actuator, sensor or eeprom)"),
    (b"\n\nrx a\\q\n", f"S:3:5: {UNKNOWN_ESCAPE}"),
    (b"rx \\x4\n", f"S:1:4: {UNKNOWN_ESCAPE}"),
    (b"rx a\\\n", f"S:1:5: {UNKNOWN_ESCAPE}"),
    (b"rx a\tb\n", r"S:1:5: character U+0009 in rx text (write its bytes as \xHH)"),
    ("rx caf\u00e9\\r\n".encode(), r"S:1:7: character U+00E9 in rx text (write its bytes as \xHH)"),
    # raw control bytes: refused anywhere, with the escape to write instead
    (b"rx v\x0bx\n", r"S:1:5: control character 0x0B (in an rx text write it as \x0B)"),
    (b"rx v\x0c\n", r"S:1:5: control character 0x0C (in an rx text write it as \x0C)"),
    (b"rx v\x1c\n", r"S:1:5: control character 0x1C (in an rx text write it as \x1C)"),
    (b"rx v\rx\r\n", r"S:1:5: control character 0x0D (in an rx text write it as \x0D)"),
    (b"boot\r\r\n", r"S:1:5: control character 0x0D (in an rx text write it as \x0D)"),
    (b"# a \x00 comment\n", r"S:1:5: control character 0x00 (in an rx text write it as \x00)"),
    # not UTF-8: at the byte, after the trace of the lines before
    (b"# caf\xe9\n", "S:1:6: not UTF-8 text (byte 0xE9)"),
    (b"  rx \xe2\x82\n", "S:1:6: not UTF-8 text (byte 0xE2)"),
    (b"rx \xed\xa0\x80\n", "S:1:4: not UTF-8 text (byte 0xED)"),          # a surrogate
    (b"rx \xc0\xaf\n", "S:1:4: not UTF-8 text (byte 0xC0)"),              # overlong
    (b"rx \xe2\x0b\n", "S:1:4: not UTF-8 text (byte 0xE2)"),
    ("# \u00e9\u00e9 \x07\n".encode(), r"S:1:6: control character 0x07 (in an rx text write it as \x07)"),
])
def test_bad_script_same_error_on_both_sides(hosts, capsys, tmp_path, script, message):
    check(hosts, capsys, tmp_path, script, message)


def test_the_trace_before_the_error_is_the_same(hosts, capsys, tmp_path):
    out = check(hosts, capsys, tmp_path, b"boot\nrx v\\r\n\xff\ntick\n",
                "S:3:1: not UTF-8 text (byte 0xFF)")
    assert out.splitlines()[-1].startswith("TX 4F4B2065")          # v's reply came first


@pytest.mark.parametrize("name, reason", [("none.txt", "No such file or directory"),
                                          ("folder", "Is a directory")])
def test_unreadable_script(hosts, capsys, tmp_path, name, reason):
    (tmp_path / "folder").mkdir()
    path = tmp_path / name
    status = harness_main([PAPAMAN, str(path)])
    out, err = capsys.readouterr()
    assert (status, out, err) == (1, "", f"error: cannot read {path}: {reason}\n")
    for binary in hosts:
        proc = subprocess.run([str(binary), str(path)], capture_output=True, text=True)
        assert (proc.returncode, proc.stdout, proc.stderr) == (status, out, err)


@pytest.mark.parametrize("script", [
    b"boot\nrx " + b"v" * 100_000 + b"\\r\ntick\nrx t\\r\ntick\n",          # 100 kB rx line
    b"boot\n# " + b"tick 5 " * 3000 + b"\nrx v\\r\n",                         # long comment
    b"boot\r\n\t rx v\\r\r\n\ttick 2\t# tabs, CRLF\r\nrx x\\r",                  # no final LF
    "boot\n# caf\u00e9 \u2028 \u0085 comments hold any UTF-8\nrx v\\r\n".encode(),
])
def test_good_scripts_same_trace(hosts, capsys, tmp_path, script):
    path = tmp_path / "s.txt"
    path.write_bytes(script)
    status, out, err = both(hosts, capsys, path)
    assert (status, err) == (0, "")
    assert out.count("\nTX ") >= 2


# -- Intel HEX images ---------------------------------------------------------------------

def record(kind: int, addr: int, data: bytes, fix: int = 0) -> bytes:
    body = bytes([len(data), addr >> 8, addr & 0xFF, kind]) + data
    return b":" + (body + bytes([(-sum(body) + fix) & 0xFF])).hex().upper().encode() + b"\n"


EOF = record(1, 0, b"")
BAD_HEX = {
    "zz_address": (b":10ZZ0000" + b"00" * 17 + b"\n", "Hex file contains invalid record at line 1"),
    "empty_04": (b":00000004FC\n", "Invalid Extended Linear Address Record at line 1"),
    "empty_02": (record(2, 0, b""), "Invalid Extended Segment Address Record at line 1"),
    "odd_digits": (record(0, 0, b"\x01")[:-2] + b"\n", "Hex file contains invalid record at line 1"),
    "short": (b":0000\n", "Hex file contains invalid record at line 1"),
    "no_colon": (b"\n\n 00000001FF\n", "Hex file contains invalid record at line 3"),
    "not_ascii": (b":\xff\xfe\n", "Hex file contains invalid record at line 1"),
    "length": (record(0, 0, b"\x01\x02")[:-3] + b"\n", "Record at line 1 has invalid length"),
    "type": (record(6, 0, b""), "Record at line 1 has invalid record type"),
    "checksum": (record(0, 0, b"\x01", fix=1), "Record at line 1 has invalid checksum"),
    "overlap": (record(0, 4, b"\x01\x02") + record(0, 5, b"\x03"),
                "Hex file has data overlap at address 0x5 on line 2"),
    "overlap_far": (record(4, 0, b"\x00\x01") + record(0, 0x10, b"\x01")
                    + record(0, 0x10, b"\x02"),
                    "Hex file has data overlap at address 0x10010 on line 3"),
    "eof_data": (record(1, 0, b"\x00"), "File has invalid End-of-File record"),
    "start_twice": (record(5, 0, b"\0\0\0\0") + record(3, 0, b"\0\0\0\0"),
                    "Start Address Record appears twice at line 2"),
    "start_bad": (record(3, 0, b"\0\0"), "Invalid Start Segment Address Record at line 1"),
    "cr_lines": (record(0, 0, b"\x01").rstrip(b"\n") + b"\r\r" + record(7, 0, b""),
                 "Record at line 3 has invalid record type"),
}


@pytest.mark.parametrize("name", sorted(BAD_HEX))
def test_bad_hex_same_error_on_both_sides(hosts, capsys, tmp_path, name):
    data, reason = BAD_HEX[name]
    (tmp_path / "bad.hex").write_bytes(data)
    check(hosts, capsys, tmp_path, b"image bad.hex\nboot\n",
          f"S:1:1: D/bad.hex: not a valid Intel HEX file ({reason})")


def test_hex_beyond_the_eeprom_and_missing(hosts, capsys, tmp_path):
    (tmp_path / "far.hex").write_bytes(record(0, 0x7FFF, b"\x01\x02") + EOF)
    check(hosts, capsys, tmp_path, b"image far.hex\n",
          "S:1:1: D/far.hex: data at address 0x8000, beyond the 32768-byte EEPROM")
    check(hosts, capsys, tmp_path, b"boot\nimage none.hex\n",
          "S:2:1: cannot read D/none.hex: No such file or directory")


def test_good_hex_variants_load_alike(robot, hosts, capsys, tmp_path):
    """CR line ends, lower-case digits, blank lines, anything after the EOF record."""
    write_hex(build_image(robot), tmp_path / "img.hex")
    text = (tmp_path / "img.hex").read_bytes()
    (tmp_path / "img.hex").write_bytes(b"\n" + text.lower().replace(b"\n", b"\r")
                                       + b"\xff garbage after the end")
    (tmp_path / "s.txt").write_bytes(b"image img.hex\nboot\nrx PLY01\\r\ntick 3\n")
    status, out, err = both(hosts, capsys, tmp_path / "s.txt")
    assert (status, err) == (0, "")
    replies = [bytes.fromhex(line[3:]) for line in out.splitlines() if line.startswith("TX ")]
    assert replies[:2] == [ready(robot), b"OK\r\n"]
