"""STARFISH's boards twice (issue 22, item 6 in part): the generated C cores built on the
host (gcc -Werror, plain and under ASan+UBSan) and the Python cores give the same trace
for the same stimulus, on hand-written and hypothesis-generated scripts: the central
board's replies, I2C writes and watchdog stops; the drive board's duties and direction
pins tick by tick. (The PIC ports are not written yet.)"""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from esair_min.codegen import generate_robot
from esair_min.components.omni_base.core import velocity_line, wheels_line
from esair_min.components.dc_motor.harness import run_script as run_drive
from esair_min.components.omni_base.harness import run_script
from esair_min.core.protocol import add_checksum


@pytest.fixture(scope="module")
def hosts(starfish, tmp_path_factory):
    """The central board's host build, plain and sanitized: {name: binary}."""
    out = tmp_path_factory.mktemp("starfish")
    result = generate_robot(starfish, out)
    assert result.boards == ("central", "drive") and result.skipped == ()
    bins = {}
    for role in result.boards:
        board = out / role
        subprocess.run(["make", "-s", "host"], cwd=board, check=True)
        subprocess.run(["make", "-s", "host", "HOST_BIN=firmware_asan",
                        "SANITIZE=-fsanitize=address,undefined -fno-sanitize-recover=all"],
                       cwd=board, check=True)
        bins[role] = {"plain": board / "firmware_host", "asan": board / "firmware_asan"}
    return bins


def run_c(binary: Path, script: str, tmp_path: Path) -> list[str]:
    path = tmp_path / "script.txt"
    path.write_text(script)
    run = subprocess.run([str(binary), str(path)], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    return run.stdout.splitlines()


HAND = """rx v
rx V+0200+0000+0000
flow 0 10 -3 88
flow 1 9 2 90
tick 2
rx O
rx W+0601+0000+0000
rx V+0000+0000-0100
tick 60
rx O*00
rx O
nack 1
rx x
nack 0
raw 41 80 0D 0A
rx VVVVVVVVVVVVVVVVVVVVVVVVVVVVVVVVVVVVVVVVVVVV
rx V+0500-0500+0000
rx V+0501+0000+0000
rx W-0600+0600-0600
tick 51
tick 200
rx -0000
rx V-0000-0000-0000
"""


def test_hand_script_gives_the_same_trace(starfish, hosts, tmp_path):
    want = run_script(starfish, HAND)
    assert want[:4] == ["TX OK esair-min/1 starfish wheels=3 flow=2 watchdog=500 checksum=off",
                        "W 30 00 38 FF 64 00 64 00 ACK", "TX OK",
                        "TX OK n=2 a=10,-3,88 b=9,2,90"]
    assert want.count("TX !W watchdog stop") == 2
    for binary in hosts["central"].values():
        assert run_c(binary, HAND, tmp_path) == want


def _line() -> st.SearchStrategy[str]:
    num = st.integers(-9999, 9999)
    valid = st.one_of(
        st.builds(velocity_line, st.integers(-600, 600), st.integers(-600, 600),
                  st.integers(-3500, 3500)),
        st.builds(lambda a, b, c: wheels_line([a, b, c]), num, num, num),
        st.sampled_from(["O", "x", "v", "o", "V", "W+1", "O1", ""]),
    )
    text = st.text(st.characters(min_codepoint=0x20, max_codepoint=0x7E), max_size=45)
    return st.one_of(valid, valid.map(add_checksum), text)


_step = st.one_of(
    _line().map(lambda t: f"rx {t}"),
    st.lists(st.integers(0, 255), min_size=1, max_size=50).map(
        lambda bs: "raw " + " ".join(f"{b:02X}" for b in bs)),
    st.integers(1, 80).map(lambda n: f"tick {n}"),
    st.tuples(st.integers(0, 1), st.integers(-128, 127), st.integers(-128, 127),
              st.integers(0, 255)).map(lambda t: "flow {} {} {} {}".format(*t)),
    st.sampled_from(["nack 0", "nack 1"]),
)


@settings(max_examples=150, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(_step, min_size=1, max_size=40))
def test_generated_scripts_give_the_same_trace(starfish, hosts, tmp_path, steps):
    script = "\n".join(steps) + "\n"
    assert run_c(hosts["central"]["plain"], script, tmp_path) == run_script(starfish, script)


@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(_step, min_size=1, max_size=40))
def test_generated_scripts_under_the_sanitizers(starfish, hosts, tmp_path, steps):
    script = "\n".join(steps) + "\n"
    assert run_c(hosts["central"]["asan"], script, tmp_path) == run_script(starfish, script)


DRIVE = """write 0 58 02
tick 3
write 2 9C FF 00 80
tick 40
write 5 01 02 03
tick 1
write 0 00 00 00 00 00 00
tick 35
"""


def test_drive_hand_script(starfish, hosts, tmp_path):
    want = run_drive(starfish.board("drive"), DRIVE)
    assert want[:3] == ["T 6/1 0/1 0/1", "T 13/1 0/1 0/1", "T 20/1 0/1 0/1"]
    assert want[43] == "T 203/1 33/0 197/0" and want[-1] == "T 0/1 0/1 0/1"
    for binary in hosts["drive"].values():
        assert run_c(binary, DRIVE, tmp_path) == want


_drive_step = st.one_of(
    st.tuples(st.integers(0, 7), st.lists(st.integers(0, 255), min_size=1, max_size=8)).map(
        lambda t: f"write {t[0]:X} " + " ".join(f"{b:02X}" for b in t[1])),
    st.integers(1, 60).map(lambda n: f"tick {n}"),
)


@settings(max_examples=100, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(_drive_step, min_size=1, max_size=30))
def test_drive_generated_scripts(starfish, hosts, tmp_path, steps):
    script = "\n".join(steps) + "\n"
    want = run_drive(starfish.board("drive"), script)
    assert run_c(hosts["drive"]["plain"], script, tmp_path) == want
    for row in want:                               # no duty above what the limit gives
        assert all(int(m.split("/")[0]) <= 203 for m in row.split()[1:])
