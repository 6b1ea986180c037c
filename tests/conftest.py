"""Fixtures shared by the test modules."""

import compileall
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest

from esair_min.codegen import generate_robot
from esair_min.core.image import build_image, write_hex
from esair_min.pic.build import BuildError, build_board, toolchain
from esair_min.model.validate import load_robot

ROOT = Path(__file__).resolve().parent.parent


def pytest_configure(config):
    """ESAIR's cache (build ids, checked deployments) in a folder of this run, shared by
    its workers and the processes they start, not the user's (removed at the end)."""
    if "PYTEST_XDIST_WORKER" not in os.environ and "ESAIR_TEST_CACHE_OWNER" not in os.environ:
        os.environ["ESAIR_CACHE"] = tempfile.mkdtemp(prefix="esair-test-cache-")
        os.environ["ESAIR_TEST_CACHE_OWNER"] = str(os.getpid())


def pytest_unconfigure(config):
    if os.environ.get("ESAIR_TEST_CACHE_OWNER") == str(os.getpid()):
        shutil.rmtree(os.environ["ESAIR_CACHE"], ignore_errors=True)


def pytest_sessionstart(session):
    """The checkout's modules compiled once (the controller, or the one process of
    ``-n 0``): each child the tests start (``esair``, an emulator, a robot's agents)
    loads them instead of compiling the sources again at its start, which it does where
    PYTHONDONTWRITEBYTECODE is set (Python then reads byte code, never writes it)."""
    if "PYTEST_XDIST_WORKER" not in os.environ:
        for folder in ("esair_min", "esair_std", "codegen", "tests/support", "bench/toolkit"):
            compileall.compile_dir(ROOT / folder, quiet=1)


@pytest.fixture(scope="session")
def robot():
    """The validated PAPA-MAN robot of boards/papaman (frozen: safe to share)."""
    return load_robot(ROOT / "boards" / "papaman")


@pytest.fixture(scope="session")
def starfish():
    """The validated STARFISH robot of boards/starfish (frozen: safe to share)."""
    return load_robot(ROOT / "boards" / "starfish")


@pytest.fixture(scope="session")
def pic_firmware(robot, tmp_path_factory):
    """PAPA-MAN's generated firmware, each board built for the PIC18F452 on first use:
    ``pic_firmware("central")`` is the board's folder (``build-pic/firmware.cod`` in
    it). Without the toolchain the test fails with the install hint."""
    try:
        tc = toolchain()
    except BuildError as exc:
        pytest.fail(str(exc), pytrace=False)
    out = tmp_path_factory.mktemp("pic")
    generate_robot(robot, out)
    built: dict[str, Path] = {}

    def board(role: str) -> Path:
        if role not in built:
            build_board(out / role, tc)
            built[role] = out / role
        return built[role]

    return board


@pytest.fixture(scope="session")
def papaman_boot(tmp_path_factory):
    """PAPA-MAN generated, its central alone built as ``esair build`` does (the
    bootloader and ``firmware-app.hex`` included): a BoardBuild. A flash of the central
    needs nothing of the other boards (``esair flash``/``esair run`` check only the
    flashed board's .hex); without the toolchain the test fails with the install hint."""
    from esair_min.pic.bootbuild import build_boot
    from esair_min.pic.build import BoardBuild
    from esair_min.resources import resolve_robot

    try:
        tc = toolchain()
    except BuildError as exc:
        pytest.fail(str(exc), pytrace=False)
    out = tmp_path_factory.mktemp("boot")
    generate_robot(load_robot(resolve_robot("papaman")), out)
    folder = out / "central"
    usage = build_board(folder, tc)
    return BoardBuild("central", folder, usage, "pic18f452",
                      build_boot(folder, tc, "papaman", "central"))


#: gcc flags of the sanitized host builds (address and undefined behaviour, no recovery)
SANITIZE = "-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer"


@pytest.fixture(scope="session")
def central_host(robot, tmp_path_factory):
    """PAPA-MAN's central board built for the host port, plainly (``plain``) and with
    ASan+UBSan (``san``), in ``dir`` with the EEPROM image ``papaman.hex``."""
    out = tmp_path_factory.mktemp("gen")
    generate_robot(robot, out)
    central = out / "central"
    for args in (["HOST_BIN=firmware_host"],
                 ["HOST_BIN=firmware_host_san", f"SANITIZE={SANITIZE}"]):
        proc = subprocess.run(["make", "-s", "host", *args], cwd=central,
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stdout + proc.stderr
    write_hex(build_image(robot), central / "papaman.hex")
    return {"plain": central / "firmware_host", "san": central / "firmware_host_san",
            "dir": central}


@pytest.fixture(scope="session")
def fast_robot(tmp_path_factory):
    """PAPA-MAN with its UART at 115200 baud (a test-only copy): 64 bytes arrive within
    one tick, so a held write can overrun the receive ring on the PIC in gpsim and in
    the emulator as in the Python harness (which has no line rate)."""
    folder = tmp_path_factory.mktemp("fast") / "papaman"
    folder.mkdir()
    for path in (ROOT / "boards" / "papaman").glob("*.yaml"):
        text = path.read_text()
        if path.name == "central.yaml":
            assert text.count("baud: 9600") == 1
            text = text.replace("baud: 9600", "baud: 115200")
        (folder / path.name).write_text(text)
    robot = load_robot(folder)
    assert robot.central.uart.baud == 115200
    return robot


# --- markers (registered in pyproject.toml) -------------------------------------------
# A test is marked by what it needs: its folder (net, hmi), its module's ``pytestmark``
# (gpsim, pty, avr, slow), or the fixtures it takes. A test that needs a simulator, a
# pty, a network or a browser is also ``slow``, as is every process-mode run;
# `-m "not slow"` is the fast loop.
_BY_FOLDER = {"net": "net", "hmi": "browser"}
_BY_FIXTURE = {"pic_firmware": "gpsim", "papaman_boot": "gpsim"}
_SLOW_NEEDS = {"net", "browser", "gpsim", "avr", "pty"}


def _in_process_mode(item) -> bool:
    """An STD test's process-mode run: each component starts an interpreter of its own
    (seconds a test); the fast loop runs the same rules in thread mode, the full suite
    in both."""
    callspec = getattr(item, "callspec", None)
    return callspec is not None and "process" in callspec.params.values()


def pytest_xdist_auto_num_workers(config) -> int:
    """``-n auto``: one worker more than the cores. Most STD, HMI, network and flashing
    tests spend much of their time waiting on a robot's line, a browser or a cut link;
    a third worker on two cores fills that wait (README, "Contributing")."""
    return len(os.sched_getaffinity(0)) + 1


#: The longest modules, longest first (--durations=0 of a whole run, summed per module).
#: pytest-xdist hands whole modules to its workers in collection order (--dist loadfile
#: with --no-loadscope-reorder; its default order, most tests first, ran the two network
#: modules of 2 tests and 11 last), one to each worker in turn: started first, they no
#: longer leave one worker running alone at the end. The two network modules go to one
#: worker's queue one after the other, never side by side (both cut links and load the
#: CPU): the second is moved to the place that worker's next module takes.
LONGEST_FIRST = ["test_starfish_net", "test_foxglove", "test_std_net", "test_verify",
                 "test_starfish_std", "test_hmi_papaman", "test_std_papaman",
                 "test_std_operator_cli", "test_pic_bootloader", "test_hmi_stop",
                 "test_pic_flash_cli", "test_std_papaman_safety", "test_flash_avr", "test_std_stop",
                 "test_hmi_truth", "test_avr", "test_pty_promise", "test_gpsim", "test_eeprom_link",
                 "test_gpsim_slaves", "test_std_cli", "test_doctor", "test_validate_fuzz",
                 "test_differential", "test_decoder_props", "test_validate_errors",
                 "test_fast_paths", "test_overrun", "test_std_record",
                 "test_delivered_means_delivered", "test_std_net_security",
                 "test_std_first_behavior", "test_std_supervision", "test_hmi_starfish", "test_pty",
                 "test_minlink_safety", "test_cli_manner", "test_hmi_security",
                 "test_std_papaman_cli", "test_std_bs"]


def pytest_collection_modifyitems(config, items):
    tests = Path(__file__).resolve().parent
    order = [stem for stem in LONGEST_FIRST if stem != "test_std_net"]
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    order.insert(workers, "test_std_net")          # gw0's second: after test_starfish_net
    rank = {stem: i for i, stem in enumerate(order)}
    items.sort(key=lambda item: rank.get(item.path.stem, len(rank)))   # stable: the rest as is
    for item in items:
        rel = item.path.resolve().relative_to(tests).parts
        names = set()
        if len(rel) > 1 and rel[0] in _BY_FOLDER:
            names.add(_BY_FOLDER[rel[0]])
        names |= {mark for fix, mark in _BY_FIXTURE.items() if fix in item.fixturenames}
        names |= {m.name for m in item.iter_markers()}
        if names & _SLOW_NEEDS or _in_process_mode(item):
            names.add("slow")
        for name in sorted(names - {m.name for m in item.iter_markers()}):
            item.add_marker(getattr(pytest.mark, name))
