"""The generated C core, built on the host, against the Python core: identical traces.

The central board's firmware is generated for PAPA-MAN and built with gcc (warnings are
errors), once plainly and once under AddressSanitizer and UBSan. Both it and the Python
harness (esair_min.core.stimulus) run the same stimulus scripts (docs/trace-format.md);
their traces must be equal line for line (``@`` time marks ignored).
"""

from __future__ import annotations

import random
import subprocess
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from esair_min.core.stimulus import run_script
from esair_min.core.protocol import add_checksum
from esair_min.core.trace import without_marks
from tests.support.overrun_streams import scripts as overrun_scripts

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "tests" / "scenarios" / "papaman.txt"


@pytest.fixture(scope="module")
def firmware(central_host):
    """Paths of the plain and the sanitized host build of the central board."""
    return central_host


def c_trace(binary: Path, script_path: Path) -> list[str]:
    proc = subprocess.run([str(binary), str(script_path)], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stderr == "", proc.stderr[-3000:]
    return without_marks(proc.stdout)


def py_trace(robot, script: str, path: Path) -> list[str]:
    return without_marks(run_script(robot, script, str(path)))


def assert_same(c: list[str], py: list[str]) -> None:
    if c != py:
        for i, (a, b) in enumerate(zip(c, py)):
            if a != b:
                ctx = "\n".join(py[max(0, i - 8):i])
                raise AssertionError(f"traces differ at line {i + 1}:\n{ctx}\n"
                                     f"C:      {a}\nPython: {b}")
        raise AssertionError(f"trace lengths differ: C {len(c)}, Python {len(py)}")


# -- command streams -----------------------------------------------------------------

def esc(data: bytes) -> str:
    """Bytes as an rx text: letters and digits as they are, everything else \\xHH."""
    return "".join(chr(b) if chr(b).isalnum() and b < 0x80 else f"\\x{b:02X}" for b in data)


digits3 = st.integers(0, 30).map(lambda v: f"{v:03d}")
motor = st.builds(lambda m, s, a: f"o{m}{s}{a:03d}", st.sampled_from("abcdefghijklmz"),
                  st.sampled_from("abcdfkz{"), st.integers(0, 999))
angle_chars = st.sampled_from("0123456789:;<=>?@ABCDEFGHIJKLMNOPQRSTUVWXYZ[]^_`abcdefghijkl.m/")
commands = st.one_of(
    st.sampled_from(["t", "v", "s", "x", "SIT", "DNC", "PLY", "PLY0", "tt", "o", "q", "",
                     "h1", "h0", "h2", "h"]),
    motor,
    st.builds(lambda n: f"PLY{n:02d}", st.integers(0, 7) | st.just(99)),
    st.builds(lambda ds: "a" + "".join(ds), st.lists(digits3, min_size=11, max_size=13)),
    st.builds(lambda cs: "c" + "".join(cs), st.lists(angle_chars, min_size=11, max_size=13)),
    st.text(st.characters(min_codepoint=0x20, max_codepoint=0x7E), max_size=45),
)


@st.composite
def command_line(draw) -> bytes:
    line = draw(commands)
    mode = draw(st.sampled_from(["plain", "plain", "checksum", "bad_checksum", "lower"]))
    if mode == "checksum":
        line = add_checksum(line)
    elif mode == "bad_checksum":
        line = add_checksum(line)[:-1] + draw(st.sampled_from("0123456789ABCDEF"))
    elif mode == "lower":
        line = add_checksum(line).lower() if line else line
    data = line.encode("ascii")
    if draw(st.integers(0, 9)) == 0:
        data = data * draw(st.integers(2, 4))          # overlong
    end = draw(st.sampled_from([b"\r\n", b"\r", b"\n", b"\n\r", b"", b"\r\n\r\n"]))
    return data + end


garbage = st.binary(min_size=1, max_size=70)
tips = st.lists(st.integers(0, 1023), min_size=8, max_size=8)
tipping = st.builds(lambda ln, r: [ln] * 4 + [r] * 4, st.integers(0, 1023), st.integers(0, 1023))

step = st.one_of(
    command_line().map(lambda b: f"rx {esc(b)}"),
    st.lists(command_line(), min_size=2, max_size=5).map(lambda bs: f"rx {esc(b''.join(bs))}"),
    garbage.map(lambda b: f"rx {esc(b)}"),
    st.integers(1, 30).map(lambda n: f"tick {n}"),
    st.just("tick"),
    (tips | tipping).map(lambda vs: "sensor " + " ".join(map(str, vs))),
    st.builds(lambda d, on: f"fault {d} {'on' if on else 'off'}",
              st.sampled_from(["actuator", "sensor", "eeprom", "bus", "sda"]), st.booleans()),
    st.builds(lambda off, v: f"poke {off:X} {v:X}", st.integers(0, 1100), st.integers(0, 255)),
    st.just("boot"),
)
scripts = st.lists(step, min_size=1, max_size=40).map(lambda steps: ["boot", *steps])


@settings(max_examples=150, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture,
                                 HealthCheck.too_slow, HealthCheck.data_too_large])
@given(scripts)
def test_hypothesis_streams_same_trace(robot, firmware, tmp_path_factory, steps):
    path = firmware["dir"] / "hyp.txt"
    script = "\n".join(steps) + "\n"
    path.write_text(script)
    assert_same(c_trace(firmware["plain"], path), py_trace(robot, script, path))


@settings(max_examples=100, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture,
                                 HealthCheck.too_slow, HealthCheck.data_too_large])
@given(overrun_scripts)
def test_overrunning_streams_same_trace(robot, firmware, steps):
    """Bursts that overrun the 64-byte receive ring while writes are held (issue 10):
    the C ring marks each loss where the Python one does."""
    path = firmware["dir"] / "hyp_overrun.txt"
    script = "\n".join(steps) + "\n"
    path.write_text(script)
    assert_same(c_trace(firmware["plain"], path), py_trace(robot, script, path))


@pytest.mark.parametrize("name", sorted(p.name for p in (ROOT / "tests" / "fixtures" / "overrun")
                                        .glob("*.txt")))
def test_overrun_scripts_same_trace(robot, firmware, name):
    """Issue 10's reproducer and the loss cases of tests/fixtures/overrun, plain and
    under ASan/UBSan."""
    path = ROOT / "tests" / "fixtures" / "overrun" / name
    py = py_trace(robot, path.read_text(), path)
    assert "TX " + b"E12 input overrun\r\n".hex().upper() in py
    for binary in ("plain", "san"):
        assert_same(c_trace(firmware[binary], path), py)


@pytest.mark.parametrize("name", ["bus.txt", "bus_boot.txt"])
def test_held_bus_scripts_same_trace(robot, firmware, name):
    """`fault bus|sda on` (SCL/SDA held low): every transfer fails in both."""
    path = ROOT / "tests" / "fixtures" / "gpsim" / name
    c = c_trace(firmware["plain"], path)
    assert sum(line.endswith(" NACK") for line in c) >= 10
    assert_same(c, py_trace(robot, path.read_text(), path))


def random_script(rng: random.Random, n_segments: int) -> str:
    """Many independent segments in one script: each restores the EEPROM, clears the
    faults and the sensors, boots, then runs random steps (for one sanitized run)."""
    ex = []
    for _ in range(n_segments):
        ex += ["image papaman.hex", "fault actuator off", "fault sensor off",
               "fault eeprom off", "sensor 0 0 0 0 0 0 0 0", "boot"]
        for _ in range(rng.randint(1, 30)):
            ex.append(_random_step(rng))
    return "\n".join(ex) + "\n"


def _random_step(rng: random.Random) -> str:
    kind = rng.random()
    if kind < 0.5:
        line = rng.choice(["t", "v", "s", "x", "SIT", "DNC", "PLY03", "PLY01", "PLY04",
                           "PLY09", f"o{rng.choice('abl')}{rng.choice('ac')}{rng.randint(0, 200):03d}",
                           "a" + "".join(f"{rng.randint(0, 26):03d}" for _ in range(12)),
                           "c" + "".join(rng.choice("0Ul.A") for _ in range(12))])
        if rng.random() < 0.3:
            line = add_checksum(line)
        end = rng.choice([b"\r\n", b"\n", b"\r"])
        return "rx " + esc(line.encode() + end)
    if kind < 0.6:
        return f"rx {esc(bytes(rng.randrange(256) for _ in range(rng.randint(1, 80))))}"
    if kind < 0.8:
        return f"tick {rng.randint(1, 25)}"
    if kind < 0.9:
        ln, r = rng.randint(0, 1023), rng.randint(0, 1023)
        return "sensor " + " ".join(map(str, [ln] * 4 + [r] * 4))
    if kind < 0.95:
        return f"fault {rng.choice(['actuator', 'sensor', 'eeprom'])} {rng.choice(['on', 'off'])}"
    return f"poke {rng.randint(0, 1069):X} {rng.randrange(256):X}"


def test_batched_streams_under_sanitizers(robot, firmware):
    """300 random segments in one run of the ASan/UBSan build."""
    path = firmware["dir"] / "batch.txt"
    script = random_script(random.Random(4), 300)
    path.write_text(script)
    c = c_trace(firmware["san"], path)
    assert_same(c, py_trace(robot, script, path))
    assert sum(1 for line in c if line.startswith("TX ")) > 1000


def test_papaman_scenario(robot, firmware):
    script = SCENARIO.read_text()
    for binary in ("plain", "san"):
        c = c_trace(firmware[binary], SCENARIO)
        assert_same(c, py_trace(robot, script, SCENARIO))
    text = "\n".join(c)
    # The scenario covers what it says it covers.
    assert "TX " + b"!R auto_balance\r\n".hex().upper() in text
    assert "TX " + b"E07 busy\r\n".hex().upper() in text
    assert "TX " + b"E04 outside limits\r\n".hex().upper() in text
    assert "TX " + b"E06 bad checksum\r\n".hex().upper() in text
    assert "R 20 00 16 NACK" in text
    assert sum(1 for line in c if line.startswith("W 10 00") and len(line) > 40) >= 8


def test_traces_differ_when_the_c_core_misbehaves(robot, firmware, tmp_path):
    """The comparison can fail: a script whose Python trace is edited must not match."""
    path = tmp_path / "s.txt"
    path.write_text("boot\nrx v\\r\\n\n")
    c = c_trace(firmware["plain"], path)
    py = py_trace(robot, path.read_text(), path)
    assert c == py
    with pytest.raises(AssertionError, match="traces differ at line"):
        assert_same(c, py[:-1] + ["TX 4F4B0D0A"])
