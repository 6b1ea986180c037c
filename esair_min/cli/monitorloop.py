"""``esair monitor``'s loop: a reader thread shows each line the board sends, time-stamped
and decoded; the main thread sends what the user types (readline: line editing and
history on a terminal). Nothing is ever sent that the user did not type."""

from __future__ import annotations

import os
import sys
import threading
import time
from pathlib import Path
from typing import Any, TextIO

from esair_min import sigs
from esair_min.errors import EsairError
from esair_min.model.robot import Robot

PROMPT = "> "
#: what each error code means (docs/protocol.md, "Replies")
MEANING = {
    "E01": "no command has this prefix", "E02": "the line has more than 40 characters",
    "E03": "wrong length or argument", "E04": "outside a servo's limits",
    "E05": "speed/angle overflow", "E06": "the *HH checksum does not match",
    "E07": "busy: a motion is playing", "E08": "no motion of that number",
    "E09": "the motion image failed its check (write it: esair eeprom)",
    "E10": "a board or the EEPROM did not acknowledge on I2C",
    "E11": "this board requires a *HH checksum", "E12": "bytes were lost: input overrun",
    "E13": "a byte outside 0x20-0x7E"}


def decode(line: str, robot: Robot | None) -> str:
    """A few words on what a board's line means ('' when it speaks for itself)."""
    body = line[1:] if line.startswith("!") else line
    if line.startswith("!READY"):
        words = line.split()
        proto = words[1] if len(words) > 1 else "?"
        rest = " ".join(words[2:])
        what = f"board reset and ready: protocol {proto}"
        if rest.startswith("image="):
            what += f", motion image {rest[6:]}"
        elif rest:
            what += f", robot {rest}"
        if robot is not None:
            what += f" (monitoring {robot.name})"
        return what
    if line.startswith("!R "):
        name = line[3:].strip()
        what = f"reaction {name} fired"
        if robot is not None and robot.central is not None:
            found = next((r for r in robot.central.reactions if r.name == name), None)
            what += (f": plays motion {found.motion}" if found is not None
                     else f" (no reaction '{name}' in {robot.name}'s board files)")
        return what
    code = body[:3]
    if code in MEANING and (len(body) == 3 or body[3] == " "):
        return ("notice: " if line.startswith("!") else "") + f"{code}: {MEANING[code]}"
    return ""


class Monitor:
    """What is shown: each line to the terminal (redrawing the user's half-typed line)
    and to the log."""

    def __init__(self, log: TextIO | None, tty: bool) -> None:
        self.log = log
        self.tty = tty
        self.lock = threading.Lock()
        self.received = 0
        self.start = time.time()

    def show(self, arrow: str, text: str, note: str = "") -> None:
        stamp = time.strftime("%H:%M:%S", time.localtime()) + f".{int(time.time() * 1000) % 1000:03d}"
        line = f"{stamp} {arrow} {text}" + (f"   [{note}]" if note else "")
        with self.lock:
            if self.tty and arrow == "<":
                import readline

                sys.stdout.write("\r\x1b[K" + line + "\n" + PROMPT + readline.get_line_buffer())
            elif arrow == "<":
                sys.stdout.write(line + "\n")
            sys.stdout.flush()
            if self.log is not None:
                self.log.write(line + "\n")
                self.log.flush()


def _reader(ser: Any, mon: Monitor, robot: Robot | None, stop: threading.Event,
            lost: list[str]) -> None:
    import serial

    buf = bytearray()
    while not stop.is_set():
        try:
            got = ser.read(256)
        except (serial.SerialException, OSError, ValueError) as exc:
            from esair_min.serialport import describe

            lost.append(describe(exc))
            os.kill(os.getpid(), 2)      # wake the main thread's input() (SIGINT)
            return
        buf += got
        while b"\n" in buf:
            raw, _, rest = bytes(buf).partition(b"\n")
            buf = bytearray(rest)
            text = raw.decode("latin-1").rstrip("\r")
            if not text:
                continue
            mon.received += 1
            mon.show("<", text, decode(text, robot))


def _history_file() -> Path:
    return Path(os.environ.get("XDG_STATE_HOME", Path.home() / ".local" / "state")) \
        / "esair" / "monitor_history"


def run_monitor(port: str, baud: int, robot: Robot | None, log_path: Path | None,
                ser: Any = None) -> int:
    """Monitor ``port`` until Ctrl-C (status 130) or the port is lost (EsairError);
    ``ser``: the port already open (esair run keeps it open: reopening resets an Arduino)."""
    from esair_min.cli.send import open_port

    log = None
    if log_path is not None:
        try:
            log = log_path.open("a", encoding="utf-8")  # closed in the finally below
        except OSError as exc:
            raise EsairError(f"cannot write {log_path}: {exc.strerror}") from None
    try:
        if ser is None:
            ser = open_port(port, baud, 0.1)
        else:
            ser.timeout = 0.1
    except EsairError:
        if log is not None:
            log.close()
        raise
    tty = sys.stdin.isatty() and sys.stdout.isatty()
    mon = Monitor(log, tty)
    stop = threading.Event()
    lost: list[str] = []
    hist = _history_file()
    if tty:
        import readline

        try:
            readline.read_history_file(hist)
        except OSError:
            pass
    reader = threading.Thread(target=_reader, args=(ser, mon, robot, stop, lost), daemon=True)
    status = 130
    try:
        # the banner first: the reader's lines clear the prompt's row as they arrive
        print(f"monitoring {port}" + (f" at {baud} baud" if "://" not in port else "")
              + ": type a command and Enter to send it; Ctrl-C ends", file=sys.stderr,
              flush=True)
        reader.start()
        while True:
            text = input(PROMPT) if tty else sys.stdin.readline()
            if not tty and text == "":
                sigs.wait(stop)         # stdin ended: keep showing until Ctrl-C (any thread's)
                continue
            text = text.rstrip("\r\n")
            if not text:
                continue
            try:
                text.encode("ascii")
            except UnicodeEncodeError:
                print("not sent: the board takes ASCII only", file=sys.stderr)
                continue
            ser.write(text.encode("ascii") + b"\r\n")
            mon.show(">", text)
    except KeyboardInterrupt:
        pass
    except EOFError:                    # Ctrl-D on a terminal
        status = 0
    finally:
        stop.set()
        try:
            reader.join(2.0)           # its reads time out in 0.1 s: then the port closes
        except RuntimeError:           # Ctrl-C came before the reader had started
            pass
        if tty:
            import readline

            try:
                hist.parent.mkdir(parents=True, exist_ok=True)
                readline.write_history_file(hist)
            except OSError:
                pass
        ser.close()
        if log is not None:
            log.close()
    if lost:
        raise EsairError(f"{port}: {lost[0]}")
    print(("\n" if tty else "") + f"monitor stopped: {mon.received} lines received",
          file=sys.stderr)
    return status
