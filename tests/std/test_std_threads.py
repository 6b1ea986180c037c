"""transport/threads.py: a stop() that joins the runtime's threads while one of them is
being started never meets a thread not yet started (Thread.join raises RuntimeError
'cannot join thread before it is started'). Not a mode rule: the same class serves both
modes."""

import threading

from esair_std.transport.threads import Threads


def test_join_waits_for_a_thread_being_started(monkeypatch):
    threads = Threads()
    entered, go = threading.Event(), threading.Event()
    real_start = threading.Thread.start

    def slow_start(self):                 # the worker's start() is under way ...
        if self.name == "slow":
            entered.set()
            go.wait(10)
        real_start(self)
    monkeypatch.setattr(threading.Thread, "start", slow_start)
    starter = threading.Thread(target=threads.start, args=(lambda: None,),
                               kwargs={"name": "slow"})
    starter.start()
    assert entered.wait(10)
    out: list = []

    def join():                           # ... when a stop() joins them all
        try:
            out.append(threads.join(10))
        except RuntimeError as exc:
            out.append(exc)
    joiner = threading.Thread(target=join)
    joiner.start()
    joiner.join(0.5)                      # time to reach the join (it fails at once if it can)
    go.set()
    joiner.join(10)
    starter.join(10)
    assert out == [[]]                    # waited, and the worker had ended
