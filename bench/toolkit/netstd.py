"""Running ESAIR STD across network namespaces: a control center (``esair std run``,
process mode) on one host, remote agents (``esair std agent``) on others, and the
control CLI (``esair std ls/get/inspect``) — all real processes (the namespaces of esair_std/netsim.py)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
from pathlib import Path

from esair_std import netsim

ROOT = Path(__file__).resolve().parents[2]
HERE = ROOT  # processes start in the checkout, so bench.toolkit imports in them
PORT = 7447


def env() -> dict:
    e = dict(os.environ)
    e["PYTHONPATH"] = os.pathsep.join([str(ROOT), e.get("PYTHONPATH", "")])
    e["PYTHONUNBUFFERED"] = "1"
    return e


def cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "esair_min.cli", "std", *args]


class Proc:
    """A process in a namespace whose output is collected line by line."""

    def __init__(self, host: netsim.Host, cmd: list[str], cwd: Path = HERE):
        self.host = host
        self.proc = host.popen(*cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                               stdin=subprocess.DEVNULL, text=True, env=env(), cwd=str(cwd))
        self.lines: list[str] = []
        self._t = threading.Thread(target=self._read, daemon=True)
        self._t.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))

    def output(self) -> str:
        return "\n".join(self.lines)

    def wait_line(self, text: str, timeout: float = 30.0) -> str:
        def seen():
            if self.proc.poll() is not None and not any(text in ln for ln in self.lines):
                raise AssertionError(f"process exited ({self.proc.returncode}) before "
                                     f"{text!r}:\n{self.output()}")
            return next((ln for ln in self.lines if text in ln), None)
        return netsim.wait_for(seen, timeout, what=repr(text))

    def wait_exit(self, timeout: float = 30.0) -> int:
        self.proc.wait(timeout)
        self._t.join(5)
        return self.proc.returncode


#: the command server: ``esair std ARGS`` by the command line's click entry, a JSON line of
#: arguments in, a JSON line [status, stdout, stderr] out
_SERVE = """
import json, sys, traceback
from click.testing import CliRunner
from esair_min.cli import main
for line in sys.stdin:
    r = CliRunner().invoke(main, ["std", *json.loads(line)], env={"COLUMNS": "200"},
                           prog_name="esair")
    err = r.stderr
    if r.exception is not None and not isinstance(r.exception, SystemExit):
        err += "".join(traceback.format_exception(r.exception))
    print(json.dumps([r.exit_code, r.stdout, err]), flush=True)
"""


class Commands:
    """``esair std`` commands run on ``host`` one after the other by one interpreter
    there: a poll of a remote robot's state costs a command, not an interpreter's start
    (a wait polls often). Ended with the namespaces (Net.close)."""

    def __init__(self, host: netsim.Host, session: str | None = None):
        e = env()
        if session is not None:                  # a login (ESAIR_STD_SESSION)
            e["ESAIR_STD_SESSION"] = session
        self.proc = host.python("-c", _SERVE, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                stderr=subprocess.DEVNULL, text=True, env=e, cwd=str(HERE))
        self._lock = threading.Lock()

    def run(self, *args: str, timeout: float = 60.0) -> tuple[int, str, str]:
        """(exit status, standard output, standard error) of ``esair std ARGS``."""
        with self._lock:
            assert self.proc.stdin is not None and self.proc.stdout is not None
            self.proc.stdin.write(json.dumps(args) + "\n")
            self.proc.stdin.flush()
            box: list[str] = []
            reader = threading.Thread(target=lambda: box.append(self.proc.stdout.readline()),
                                      daemon=True)
            reader.start()
            reader.join(timeout)
            if not box or not box[0]:
                self.proc.kill()           # its answer, late, must not be the next one's
                raise AssertionError(f"esair std {' '.join(args)}: no answer within {timeout} s "
                                     f"(command server exit status {self.proc.poll()})")
            status, out, err = json.loads(box[0])
            return status, out, err


class Center:
    """``esair std run FILE --mode MODE`` on ``host``, listening on its address."""

    def __init__(self, host: netsim.Host, folder: Path, deployment: str, tls: bool = False,
                 *extra: str, mode: str = "process", session: str | None = None):
        """``session``: ESAIR_STD_SESSION of its control commands (:meth:`ctl`), e.g. a login."""
        self.host = host
        self.session = session
        self.endpoint = f"{'tls' if tls else 'tcp'}/{host.addr}:{PORT}"
        folder.mkdir(parents=True, exist_ok=True)
        path = folder / "robot.yaml"
        path.write_text(deployment.replace("ENDPOINT", self.endpoint))
        # the namespaces' link reaches no real computer: no security needed (--insecure)
        self.run = Proc(host, cli("run", str(path), "--mode", mode, "--insecure", *extra),
                        cwd=folder)
        line = self.run.wait_line(f"running in {mode} mode", 60)
        self.robot = line.split("'")[1]
        # a secured endpoint: the runtime's loopback listener for this computer's processes
        self.local = line.split("(local: ")[1].split(")")[0] if "(local: " in line else None
        self._commands: Commands | None = None

    def ctl(self, *args: str, check: bool = True, endpoint: str | None = None) -> str:
        """An `esair std` control command run on the control center's computer (by its
        :class:`Commands`): its output, or its error when it failed."""
        if self._commands is None or self._commands.proc.poll() is not None:
            self._commands = Commands(self.host, self.session)
        args = (*args, "-e", endpoint or self.endpoint, "-r", self.robot)
        status, out, err = self._commands.run(*args)
        if check and status:
            raise AssertionError(f"esair std {' '.join(args)}: {err or out}")
        return out if not status else err

    def ls(self) -> dict[str, dict]:
        return {row["name"]: row for row in json.loads(self.ctl("ls", "--json"))["components"]}

    def state(self, name: str) -> str | None:
        return self.ls().get(name, {}).get("state")

    def get(self, name: str):
        """What behavior ``name`` provides (through the BS), decoded."""
        return json.loads(self.ctl("get", name, "--timeout", "2"))

    def inspect(self, name: str) -> dict:
        return json.loads(self.ctl("inspect", name))


def agent(host: netsim.Host, endpoint: str, name: str, class_path: str, *args: str,
          cwd: Path = HERE) -> Proc:
    """``esair std agent --connect ENDPOINT NAME module:Class ARGS`` on ``host``."""
    return Proc(host, cli("agent", "--connect", endpoint, "--host-name", f"pc-{host.addr}",
                          "--insecure", name, class_path, *args), cwd=cwd)
