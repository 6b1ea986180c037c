"""Why Runtime.stop() joins its threads (docs/std.md, "Stopping a runtime used as a
library"): on Zenoh alone, a daemon thread inside a Zenoh call while the interpreter
finalizes aborts the program ("FATAL: exception not rethrown", SIGABRT).

    python scripts/zenoh_exit_abort.py [RUNS]      # each run a fresh interpreter

Each run opens a session, starts a daemon thread in a ``get`` that nobody answers (it
returns after 0.3 s) and leaves while a large heap is being freed, so the ``get``
returns during finalization. Prints each run's exit status and the count of aborts;
``--joined`` closes the session and joins the thread first (what Runtime.stop does):
no abort.
"""

from __future__ import annotations

import os
import subprocess
import sys

CHILD = r"""
import sys, threading, zenoh
cfg = zenoh.Config()
cfg.insert_json5("mode", '"peer"')
cfg.insert_json5("scouting/multicast/enabled", "false")
s = zenoh.open(cfg)
heap = [[i] * 3 for i in range(4_000_000)]     # freed while the interpreter finalizes

def blocked():
    try:
        for _ in s.get("nobody/**", timeout=0.3):
            pass
    except Exception:
        pass

t = threading.Thread(target=blocked, daemon=True)
t.start()
if sys.argv[1] == "joined":
    s.close()
    t.join()
"""


def main() -> int:
    args = [a for a in sys.argv[1:] if a != "--joined"]
    runs = int(args[0]) if args else 6
    how = "joined" if "--joined" in sys.argv else "left"
    env = dict(os.environ, LIBC_FATAL_STDERR_="1")   # glibc's message on stderr, not the tty
    aborts = 0
    for i in range(runs):
        try:
            out = subprocess.run([sys.executable, "-c", CHILD, how], capture_output=True,
                                 text=True, timeout=60, env=env)
            status, err = out.returncode, out.stderr.strip().splitlines()
        except subprocess.TimeoutExpired:
            status, err = "hung", []
        aborts += status == -6
        print(f"run {i + 1}: status {status} {err[-1] if err else ''}".rstrip())
    print(f"{aborts} of {runs} runs aborted ({how})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
