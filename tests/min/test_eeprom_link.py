"""The motion image over the robot's own link (issue 32 item 2, docs/protocol.md "Writing
the motion image"): the verbs and every refusal on the Python core, the same traces from
the host-built C core (hypothesis drives the chunk boundaries), a blank emulated robot
written by ``esair eeprom --write`` then dancing, and cuts at random points of a write.
"""

from __future__ import annotations

import random
import shutil
import subprocess
import threading
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from esair_min.core import protocol as P
from esair_min.core.stimulus import run_script
from esair_min.core.image import build_image
from esair_min.core.trace import without_marks
from esair_min.errors import EsairError
from esair_min.imagelink import ImageLink
from esair_min.model.validate import load_robot

ROOT = Path(__file__).resolve().parents[2]
IMAGE_LEN = 1070


def rx(line: str) -> str:
    return f"rx {line}\\r\\n"


def replies(trace: list[str]) -> list[str]:
    return [bytes.fromhex(t[3:]).decode().rstrip("\r\n") for t in trace if t.startswith("TX ")]


def py(robot, lines: list[str]) -> list[str]:
    return without_marks(run_script(robot, "\n".join(lines) + "\n"))


def write_lines(image: bytes, chunk: int = 16, page: int = 64) -> list[str]:
    out, at = [], 0
    while at < len(image):
        n = min(chunk, len(image) - at, page - at % page)
        out.append(rx(P.encode_image_write(at, image[at:at + n])))
        at += n
    return out


@pytest.fixture(scope="module")
def image(robot) -> bytes:
    data = build_image(robot)
    assert len(data) == IMAGE_LEN
    return data


@pytest.fixture(scope="module")
def variant(tmp_path_factory):
    """PAPA-MAN with its dance slower (delay 2): another image, the same servos."""
    folder = tmp_path_factory.mktemp("variant") / "papaman"
    shutil.copytree(ROOT / "boards" / "papaman", folder)
    central = folder / "central.yaml"
    text = central.read_text()
    assert text.count("    number: 3\n    delay_ticks: 1\n") == 1
    central.write_text(text.replace("    number: 3\n    delay_ticks: 1\n",
                                    "    number: 3\n    delay_ticks: 2\n"))
    return load_robot(folder)


# -- the verbs on the Python core ------------------------------------------------------

def test_a_blank_eeprom_is_written_committed_and_played(robot, image):
    trace = py(robot, ["poke 0 FF", "boot", rx("PLY03")]
               + write_lines(image) + [rx("PLY03"), rx("k"), rx("v"), rx("PLY03")])
    got = replies(trace)
    crc = int.from_bytes(image[6:8], "little")
    assert got[0] == "!READY esair-min/1 image=bad build=" + got[0].rsplit("=", 1)[1]
    assert got[1] == "E09 motion image invalid"
    assert got[2:2 + 67] == ["OK"] * 67
    assert got[69] == "E09 motion image invalid"          # written, not committed
    assert got[70] == "OK"
    assert f"image=ok crc={crc:04X} checksum=off" in got[71]
    assert got[72] == "OK"
    # the header went out with its first byte 0xFF; the commit wrote the 'E' alone
    writes = [t for t in trace if t.startswith("W 50 ")]
    assert writes[0].startswith("W 50 0000FF4D0205") and writes[-1] == "W 50 000045 ACK"


def test_refusals_each_with_its_code(robot, image):
    """Every refusal answers its code and writes nothing to the EEPROM."""
    head = P.encode_image_write(0, image[:16])
    bad_sum = head[:-2] + f"{(int(head[-2:], 16) + 1) & 0xFF:02X}"
    cases = [
        (P.encode_image_write(16, image[16:32]), "E03 bad argument"),   # no write open
        (P.encode_image_write(0, image[:7]), "E03 bad argument"),       # header too short
        (bad_sum, "E06 bad checksum"),
        (head[:-1], "E03 bad argument"),                                # odd hex digits
        (head.lower(), "E03 bad argument"),                             # lower-case hex
        ("r000000", "E03 bad argument"),                                 # read 0 bytes
        ("r000011", "E03 bad argument"),                                 # more than 16
        ("r7FFE02", "OK FFFF%02X" % P.chunk_checksum(0x7FFE, bytes((255, 255)))),  # the last
        ("r7FFF02", "E03 bad argument"),                                 # past the EEPROM
        ("r00G010", "E03 bad argument"),
        ("k", "E09 motion image invalid"),                               # blank: no image
    ]
    trace = py(robot, ["poke 0 FF", "boot"] + [rx(c) for c, _ in cases])
    assert replies(trace)[1:] == [want for _, want in cases]
    assert not [t for t in trace if t.startswith("W 50 ")]


def test_an_open_write_refuses_bad_chunks_and_motions(robot, image):
    head = P.encode_image_write(0, image[:16])
    lines = [
        head,
        P.encode_image_write(4, image[4:8]),          # inside the header: E03
        P.encode_image_write(60, image[60:76]),       # crosses the page at 64: E03
        P.encode_image_write(1064, image[1064:1070] + b"\0"),   # past the image's end
        P.encode_image_write(1064, image[1064:1070]),           # its last bytes: OK
        "PLY03", "DNC", "v",
    ]
    trace = py(robot, ["boot"] + [rx(x) for x in lines])
    got = replies(trace)
    assert got[1:8] == ["OK", "E03 bad argument", "E03 bad argument", "E03 bad argument",
                        "OK", "E09 motion image invalid", "E09 motion image invalid"]
    assert " image=bad checksum=off " in got[8]
    assert not [t for t in trace if t.startswith("W 10 ")]    # nothing moved


def test_a_write_while_a_motion_plays_is_busy(robot, image):
    trace = py(robot, ["boot", rx("PLY03"), rx(P.encode_image_write(0, image[:16])),
                       rx("r000008"), rx("k")])
    assert replies(trace)[1:] == ["OK", "E07 busy", "E07 busy", "E07 busy"]


def test_another_image_of_the_same_servos_is_taken(robot, variant):
    """The firmware takes any image that checks: the variant's dance plays at its own
    delay (a frame every 2 ticks), and v reports the variant's CRC."""
    other = build_image(variant)
    assert other != build_image(robot)
    trace = py(robot, ["boot"] + write_lines(other) + [rx("k"), rx("v"), rx("PLY03"),
                                                        "tick 6"])
    got = replies(trace)
    crc = int.from_bytes(other[6:8], "little")
    assert got[-1] == "OK" and f"image=ok crc={crc:04X}" in got[-2]
    ticks_with_a_frame = [trace[i - 1] for i, t in enumerate(trace)
                          if t.startswith("W 10 00") and trace[i - 1].startswith("T ")]
    assert ticks_with_a_frame == ["T 1", "T 3", "T 5"]


def test_an_image_of_other_servos_fails_its_commit(robot, image, tmp_path):
    """An image whose directory names 11 servos (CRC made right) is refused."""
    data = bytearray(image)
    for i in range(5):
        data[8 + 6 * i + 3] = 11
    data[6:8] = (__import__("binascii").crc_hqx(bytes(data[8:]), 0xFFFF)).to_bytes(2, "little")
    trace = py(robot, ["boot"] + write_lines(bytes(data)) + [rx("k"), rx("PLY03")])
    assert replies(trace)[-2:] == ["E09 motion image invalid", "E09 motion image invalid"]


def test_i2c_scan_lists_who_acknowledges(robot):
    trace = py(robot, ["boot", rx("i"), "fault sensor on", rx("i")])
    assert replies(trace)[1:] == ["OK 10 20 50", "OK 10 50"]
    probes = [t for t in trace if t.startswith("P ")]
    assert len(probes) == 2 * (0x77 - 0x08 + 1) and probes[0] == "P 08 NACK"


def test_a_reset_in_the_middle_of_a_write_leaves_the_image_bad(robot, image):
    lines = write_lines(image)
    trace = py(robot, ["boot"] + lines[:30] + ["boot", rx("PLY03"), rx("v")])
    got = replies(trace)
    assert got[-3].startswith("!READY esair-min/1 image=bad build=")
    assert got[-2] == "E09 motion image invalid" and " image=bad " in got[-1]


# -- the host C core against the Python core ----------------------------------------------

@st.composite
def write_session(draw):
    """A write of an image in chunks of drawn sizes (some crossing a page, some with a
    bad checksum or a bad digit), with reads, plays, commits and resets among them."""
    which = draw(st.sampled_from(["whole", "whole", "part"]))
    lines: list = ["boot"]
    at = 0
    length = IMAGE_LEN if which == "whole" else 200
    while at < length:
        n = draw(st.integers(1, 16))
        lines.append(("chunk", at, n, draw(st.sampled_from(["ok"] * 8 + ["sum", "digit"]))))
        at += n
        extra = draw(st.sampled_from([None] * 6 + ["PLY03", "v", "k", "r", "boot", "i"]))
        if extra == "r":
            lines.append(rx(f"r{draw(st.integers(0, 0x7FFF)):04X}{draw(st.integers(0, 18)):02X}"))
        elif extra == "boot":
            lines.append("boot")
        elif extra is not None:
            lines.append(rx(extra))
    lines += [rx("k"), rx("v"), rx("PLY03"), "tick 3"]
    return lines


def _render(lines, image: bytes) -> str:
    out = []
    for item in lines:
        if isinstance(item, tuple):
            _, at, n, mode = item
            line = P.encode_image_write(at, image[at:at + n] or b"\0")
            if mode == "sum":
                line = line[:-1] + ("0" if line[-1] != "0" else "1")
            elif mode == "digit":
                line = line[:6] + "g" + line[7:]
            out.append(rx(line))
        else:
            out.append(item)
    return "\n".join(out) + "\n"


@settings(max_examples=12, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                 HealthCheck.large_base_example])
@given(session=write_session())
def test_chunk_boundaries_same_trace_in_c_and_python(robot, image, central_host, session):
    script = _render(session, image)
    path = central_host["dir"] / "eeprom_session.txt"
    path.write_text(script)
    proc = subprocess.run([str(central_host["plain"]), str(path)], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    c = without_marks(proc.stdout)
    p = without_marks(run_script(robot, script, str(path)))
    assert c == p


def test_the_write_script_under_sanitizers(robot, image, central_host):
    """A whole write, a cut, a rewrite and the dance on the ASan+UBSan build."""
    lines = (["poke 0 FF", "boot"] + write_lines(image)[:20] + ["boot"] + write_lines(image)
             + [rx("k"), rx("r041E10"), rx("i"), rx("PLY03"), "tick 40"])
    script = "\n".join(lines) + "\n"
    path = central_host["dir"] / "eeprom_san.txt"
    path.write_text(script)
    proc = subprocess.run([str(central_host["san"]), str(path)], capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr[-3000:]
    c = without_marks(proc.stdout)
    assert c == without_marks(run_script(robot, script, str(path)))
    assert replies(c)[-2:] == ["OK 10 20 50", "OK"]


# -- over a link: the emulated robot --------------------------------------------------

def _port(url: str):
    from esair_min.serialport import open_port
    return open_port(url, timeout=0.05)


def test_esair_url_blank_robot_written_then_dances(robot, image):
    from esair_min.imagelink import ImageLink

    port = _port(f"esair://{ROOT / 'boards' / 'papaman'}?speed=max&eeprom=blank")
    try:
        emu = port.emulator
        link = ImageLink(port, robot)
        assert link.robot_crc() is None
        done: list[int] = []
        res = link.write_image(image, lambda d, t: done.append(d))
        assert (res.chunks, res.written) == (67, 67) and done[-1] == IMAGE_LEN
        assert bytes(emu.eeprom.memory[:IMAGE_LEN]) == image
        assert link.ask("PLY03") == "OK" and emu.playing == 3
        emu.run_for(1.0)
        dance = next(m for m in robot.motions if m.name == "dance")
        assert emu.playing is None and emu.servo_targets == list(dance.frames[-1].angles)
        # written again: nothing differs, nothing written
        assert link.write_image(image).written == 0
        # one chunk spoilt: only it (and the header, which opens the write) is written
        emu.eeprom.poke(500, emu.eeprom.memory[500] ^ 1)
        assert link.ask("k") == "E09 motion image invalid"
        assert link.write_image(image).written == 2
        assert link.verify(image) == [] and link.robot_crc() == res.crc
    finally:
        port.close()


def test_cuts_at_random_points_never_leave_half_an_image(robot, variant, image, tmp_path):
    """20 cuts at random instants of writes that alternate between two images: after
    each, a fresh robot on the same EEPROM file says image=bad and refuses PLY03, or
    holds one of the two images whole; the write after the last cut succeeds."""
    from esair_min.emulator.clock import NS_PER_S
    from esair_min.imagelink import ImageLink

    file = tmp_path / "eeprom.bin"
    url = f"esair://{ROOT / 'boards' / 'papaman'}?speed=max&eeprom={file}"
    images = [image, build_image(variant)]
    crcs = {int.from_bytes(i[6:8], "little"): i for i in images}
    rng = random.Random(32)

    class Cut(Exception):
        pass

    def cut() -> None:
        raise Cut

    outcomes = set()
    for k in range(20):
        port = _port(url)
        try:
            link = ImageLink(port, robot)
            emu = port.emulator
            emu.clock.schedule(emu.clock.now + int(rng.uniform(0, 4.3) * NS_PER_S), cut)
            with pytest.raises(Cut):
                link.write_image(images[k % 2])
                link.ask("v")
                emu.run_for(10)
        finally:
            port.close()
        port = _port(url)
        try:
            link = ImageLink(port, robot)
            crc = link.robot_crc()
            play = link.ask("PLY03")
            if crc is None:
                outcomes.add("bad")
                assert play == "E09 motion image invalid"
            else:
                whole = crcs[crc]
                outcomes.add("ok")
                assert bytes(port.emulator.eeprom.memory[:len(whole)]) == whole
                assert play == "OK"
        finally:
            port.close()
    assert "bad" in outcomes
    port = _port(url)
    try:
        res = ImageLink(port, robot).write_image(images[0])
        assert res.crc == int.from_bytes(image[6:8], "little")
    finally:
        port.close()


def test_the_build_id_follows_the_generated_sources(robot, variant):
    """Stable for the same board files (another load), another for other ones; the
    generated tables carry it in the v reply and !READY texts."""
    from esair_min.codegen import render_robot
    from esair_min.codegen.buildid import central_build_id

    build = central_build_id(robot)
    assert build == central_build_id(load_robot(ROOT / "boards" / "papaman"))
    assert len(build) == 8 and int(build, 16) >= 0
    assert central_build_id(variant) != build
    tables = render_robot(robot)["central/core/es_tables.c"]
    assert tables.count(f"build={build}") == 2


# -- real processes: the CLI on a pty, the emulator killed --------------------------------

def _cli(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    import os
    import sys

    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "esair_min.cli", *args], capture_output=True,
                          text=True, timeout=timeout, env=env, cwd=ROOT)


def _emulator(file: Path):
    """``esair emulate papaman --pty --eeprom FILE`` (4x real time): (process, pty path)."""
    import os
    import sys

    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, "-m", "esair_min.cli", "emulate", "papaman",
                             "--pty", "--eeprom", str(file), "--speed", "4"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env, cwd=ROOT)
    assert proc.stdout is not None
    path = proc.stdout.readline().strip()
    assert path.startswith("/dev/"), proc.stderr.read() if proc.stderr else ""
    return proc, path


def _kill(proc) -> None:
    import signal

    if proc.poll() is None:
        proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=30)
    for f in (proc.stdout, proc.stderr):
        if f is not None:
            f.close()


@pytest.mark.pty
@pytest.mark.slow
def test_cli_writes_a_blank_robot_and_survives_sigkills(robot, variant, image, tmp_path):
    """`esair eeprom papaman --write PTY` on an emulated robot whose EEPROM file is new:
    PLY03 then dances. Then the emulator process is SIGKILLed at random moments of
    writes of the other image: each time the robot started again on the same file says
    image=bad and refuses PLY03, or holds one of the two images whole; the write after
    the kills succeeds."""
    file = tmp_path / "eeprom.bin"
    proc, port = _emulator(file)
    try:
        with _port(port) as ser:
            assert ImageLink(ser, robot).ask("PLY03") == "E09 motion image invalid"
        res = _cli("eeprom", "papaman", "--write", port)
        assert res.returncode == 0, res.stderr
        assert res.stdout.startswith("papaman: wrote 67 of 67 chunks (1070 bytes) in ")
        assert res.stdout.rstrip().endswith("image valid, CRC 0x2C20")
        with _port(port) as ser:
            link = ImageLink(ser, robot)
            assert (link.ask("PLY03"), link.ask("t")) == ("OK", "E07 busy")
        assert file.read_bytes()[:IMAGE_LEN] == image     # each page in the file at once
    except BaseException:
        _kill(proc)
        raise
    crcs = {int.from_bytes(i[6:8], "little") for i in (image, build_image(variant))}
    rng = random.Random(5)
    for _ in range(3):          # the first kill: the same emulator, its dance stopped first
        ser = _port(port)
        link = ImageLink(ser, robot)
        cut = threading.Timer(rng.uniform(0.3, 1.2), _kill, (proc,))
        cut.start()
        with pytest.raises(EsairError):
            link.write_image(build_image(variant))      # until the robot dies under it
            link.ask("v")
            time.sleep(5)
            link.ask("v")
        cut.join()
        ser.close()
        proc, port = _emulator(file)
        with _port(port) as ser:
            link = ImageLink(ser, robot)
            crc = link.robot_crc()
            play = link.ask("PLY03")
        if crc is None:
            assert play == "E09 motion image invalid"
        else:
            assert crc in crcs and play == "OK"
    try:
        with _port(port) as ser:
            link = ImageLink(ser, robot)
            assert link.write_image(image).crc == 0x2C20
            assert link.verify(image) == []
    finally:
        _kill(proc)


def test_cli_eeprom_needs_one_mode():
    res = _cli("eeprom", "papaman")
    assert res.returncode == 2
    assert "give one of -o FILE, --write PORT, --verify PORT, --read FILE" in res.stderr
    res = _cli("eeprom", "papaman", "--read", "x.hex")
    assert res.returncode == 2 and "--port goes with --read" in res.stderr


def test_cli_read_and_verify_over_an_esair_url(image, tmp_path):
    """--read FILE --port, --verify (status 0 / 1 with the hint) against in-process robots."""
    from click.testing import CliRunner

    from esair_min.cli import main
    from esair_min.core.image import read_hex

    url = f"esair://{ROOT / 'boards' / 'papaman'}?speed=max"
    runner = CliRunner()
    out = tmp_path / "back.hex"
    res = runner.invoke(main, ["eeprom", "papaman", "--read", str(out), "--port", url])
    assert res.exit_code == 0, res.output
    assert res.stdout == f"papaman: read 1070 bytes -> {out}\n"
    assert read_hex(out, 32768)[:IMAGE_LEN] == image
    res = runner.invoke(main, ["eeprom", "papaman", "--verify", url])
    assert (res.exit_code, res.stdout) == (0, "papaman: the robot holds this image (CRC 0x2C20)\n")
    res = runner.invoke(main, ["eeprom", "papaman", "--verify", url + "&eeprom=blank"])
    assert res.exit_code == 1
    assert res.stdout == (f"papaman: the robot's image differs (67 chunks: 0x0000, 0x0010, "
                          f"0x0020, 0x0030, 0x0040, 0x0050, 0x0060, 0x0070 ...; its image is "
                          f"not valid); run esair eeprom papaman --write {url}&eeprom=blank\n")
    res = runner.invoke(main, ["eeprom", "papaman", "--read", str(out), "--port",
                               url + "&eeprom=blank"])
    assert res.exit_code == 1
    assert "error: the EEPROM holds no motion image (its first bytes are ff ff ff" in res.output
