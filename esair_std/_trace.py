import os, time
_ev = []
def T(tag):
    _ev.append((time.perf_counter_ns(), tag))
    if len(_ev) >= 200:
        with open(f"/tmp/etrace/{os.getpid()}.txt", "a") as f:
            for t, g in _ev:
                f.write(f"{t} {os.getpid()} {g}\n")
        _ev.clear()
