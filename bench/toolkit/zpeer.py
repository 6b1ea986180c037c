"""A raw Zenoh session driven line by line (for the namespace tests and the bench).

    python bench/toolkit/zpeer.py CONFIG_JSON

CONFIG_JSON is a zenoh config as a JSON object (e.g. from
esair_std.transport.security_config.zenoh_config). Then each line on stdin is one command;
each answer is one JSON line on stdout:

    serve KEY              queryable on KEY replying "pong:<query payload>"     -> {"ok": "serve"}
    sub KEY                subscriber on KEY; each sample -> {"sample": KEY, "payload": ...}
    alive KEY              liveliness subscriber on KEY (history): {"alive"|"gone": KEY}
    token KEY              liveliness token on KEY                               -> {"ok": "token"}
    rtt KEY N              N queries in a row   -> {"rtt": [seconds or null, ...]}
    get KEY TIMEOUT [DATA] query; -> {"replies": [...], "errors": [...]}
    getx KEY KIND          query with a bad payload (KIND of BAD) -> {"replies": [...]}
    putx KEY KIND          publish a bad payload                         -> {"ok": "putx"}
    stream KEY HZ SECONDS [block]
                           publish 1, 2, ... HZ x SECONDS at HZ (in a thread; block: a put
                           waits for a congested link, never drops)    -> {"ok": "stream"}
    put KEY DATA           publish                                               -> {"ok": "put"}
    zid                    -> {"zid": ..., "peers": [...]}
The first answer is {"ok": "open"} or {"error": why zenoh.open failed} (then it exits).
    quit

Command answers come as {"re": ...}; samples and liveliness events as they are.
Callbacks only format a line and print it (under a lock); nothing blocks in them.
"""

import json
import queue
import subprocess
import sys
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent

_lock = threading.Lock()


def out(obj):
    obj = obj if ("sample" in obj or "alive" in obj or "gone" in obj) else {"re": obj}
    with _lock:
        sys.stdout.write(json.dumps(obj) + "\n")
        sys.stdout.flush()


BAD = {                                  # payloads no ESAIR STD key must choke on
    "binary": bytes(range(256)),
    "notjson": b"{not json",
    "array": b"[1, 2, 3]",
    "number": b"42",
    "empty": b"",
    "nulls": b'{"op": null, "from": null, "name": null, "who": null, "to": null}',
    "types": b'{"op": 7, "from": [], "to": {}, "name": 1.5, "timeout": "x", "level": []}',
    "deep": b"[" * 100000 + b"]" * 100000,
    "big": b'{"op": "offer", "data": "' + b"x" * 400_000 + b'"}',
}


def _stream(session, key, hz, seconds, block=False):
    import zenoh
    # block: a put waits for a congested link, as the runtime's streams do (bus.publisher)
    pub = session.declare_publisher(key, congestion_control=zenoh.CongestionControl.BLOCK) \
        if block else session.declare_publisher(key)
    period, n = 1.0 / hz, 0
    start = time.perf_counter()
    # HZ x SECONDS samples, each at its time or, when the computer is busy, late: the
    # count never depends on the load (a loop for SECONDS sent 996 of 1000 at load 8)
    while n < round(hz * seconds):
        n += 1
        pub.put(str(n))
        delay = start + n * period - time.perf_counter()
        if delay > 0:
            time.sleep(delay)


def main():
    import zenoh
    zenoh.init_log_from_env_or("error")
    try:
        conf = zenoh.Config()
        for key, value in json.loads(sys.argv[1]).items():
            conf.insert_json5(key, json.dumps(value))
        session = zenoh.open(conf)
    except Exception as exc:  # noqa: BLE001 - any error opening the session goes back as JSON
        out({"error": str(exc).split(" at ")[0]})
        return
    keep = []
    out({"ok": "open"})

    def on_query(query):
        data = query.payload.to_string() if query.payload is not None else ""
        query.reply(query.key_expr, f"pong:{data}")

    for line in sys.stdin:
        cmd, *args = line.strip().split(maxsplit=3)
        if cmd == "serve":
            keep.append(session.declare_queryable(args[0], on_query))
            out({"ok": "serve"})
        elif cmd == "sub":
            keep.append(session.declare_subscriber(args[0], lambda s: out(
                {"sample": str(s.key_expr), "payload": s.payload.to_string()})))
            out({"ok": "sub"})
        elif cmd == "alive":
            keep.append(session.liveliness().declare_subscriber(args[0], lambda s: out(
                {"alive" if s.kind == zenoh.SampleKind.PUT else "gone": str(s.key_expr)}),
                history=True))
            out({"ok": "alive"})
        elif cmd == "token":
            keep.append(session.liveliness().declare_token(args[0]))
            out({"ok": "token"})
        elif cmd == "get":
            replies, errors = [], []
            kw = {"payload": args[2]} if len(args) > 2 else {}
            for r in session.get(args[0], timeout=float(args[1]), **kw):
                if r.ok is not None:
                    replies.append(r.ok.payload.to_string())
                else:
                    errors.append(r.err.payload.to_string())
            out({"replies": replies, "errors": errors})
        elif cmd == "rtt":                 # rtt KEY N: N queries one after the other
            times = []
            for _ in range(int(args[1])):
                t0 = time.perf_counter()
                ok = [r for r in session.get(args[0], timeout=2.0, payload="x") if r.ok is not None]
                times.append(time.perf_counter() - t0 if ok else None)
            out({"rtt": times})
        elif cmd == "stream":              # stream KEY HZ SECONDS [block]: payloads 1, 2, 3...
            seconds, *how = args[2].split()         # the line was split 3 times only
            threading.Thread(target=_stream, args=(session, args[0], float(args[1]),
                                                   float(seconds), how == ["block"]),
                             daemon=True).start()
            out({"ok": "stream"})
        elif cmd in ("getx", "putx"):      # getx/putx KEY KIND: a bad payload of KIND
            data = BAD[args[1]]
            if cmd == "putx":
                session.put(args[0], data)
                out({"ok": "putx"})
            else:
                replies = [r.ok.payload.to_bytes()[:100000].decode(errors="replace")
                           for r in session.get(args[0], timeout=3.0, payload=data)
                           if r.ok is not None]
                out({"replies": replies})
        elif cmd == "put":
            session.put(args[0], args[1])
            out({"ok": "put"})
        elif cmd == "zid":
            info = session.info
            out({"zid": str(info.zid()), "peers": [str(z) for z in info.peers_zid()]})
        elif cmd == "quit":
            break
    keep.clear()
    session.close()


class Peer:
    """The parent side: a zpeer process on a netns Host, commands and events apart."""

    def __init__(self, host, conf: dict, timeout: float = 10.0):
        self.proc = host.python(str(HERE / "zpeer.py"), json.dumps(conf), stdin=subprocess.PIPE,
                                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        self.answers: queue.Queue = queue.Queue()
        self.events: list[dict] = []
        self._cond = threading.Condition()
        threading.Thread(target=self._read, daemon=True).start()
        self.error = self._answer(timeout).get("error")     # the session could not open

    def _read(self):
        for line in self.proc.stdout:
            if not line.startswith("{"):
                continue                                  # zenoh's own log lines
            obj = json.loads(line)
            if "re" in obj:
                self.answers.put(obj["re"])
            else:
                with self._cond:
                    self.events.append(obj)
                    self._cond.notify_all()

    def _answer(self, timeout):
        try:
            return self.answers.get(timeout=timeout)
        except queue.Empty:
            raise AssertionError(f"zpeer gave no answer within {timeout} s") from None

    def cmd(self, line: str, timeout: float = 10.0):
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()
        return self._answer(timeout)

    def get(self, key: str, timeout: float = 1.0, data: str = "hi") -> list[str]:
        return self.cmd(f"get {key} {timeout} {data}", timeout + 10)["replies"]

    def wait_event(self, pred, timeout: float = 5.0):
        """The first event for which pred is true (waiting up to timeout), or None."""
        end = time.monotonic() + timeout
        with self._cond:
            while True:
                for ev in self.events:
                    if pred(ev):
                        return ev
                left = end - time.monotonic()
                if left <= 0:
                    return None
                self._cond.wait(left)

    def samples(self, key: str) -> list[str]:
        with self._cond:
            return [e["payload"] for e in self.events if e.get("sample") == key]

    def close(self):
        if self.proc.poll() is None:
            try:
                self.proc.stdin.write("quit\n")
                self.proc.stdin.flush()
                self.proc.wait(timeout=5)
            except (OSError, subprocess.TimeoutExpired):
                self.proc.kill()
                self.proc.wait()


if __name__ == "__main__":
    main()
