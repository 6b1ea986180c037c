"""Where a newcomer stumbled on the command line (issue 34 item 5): a headless run whose
behavior failed exits non-zero naming it; commands started as a shell's background job
(SIGINT ignored) keep ignoring the Ctrl-C typed for the foreground job."""

import os
import signal
import subprocess
import sys

import pytest

from tests.support.std import MODES, ROOT, esair, free_endpoint, wait_for

FAILING = """\
robot: t
behaviors:
  steady:
    class: tests.support.comps:Faulty
  broken:
    class: tests.support.comps:Faulty
    fail: raise
"""


@pytest.mark.parametrize("mode", MODES)
def test_a_headless_run_whose_behavior_failed_exits_1_naming_it(mode, tmp_path):
    dep = tmp_path / "t.yaml"
    dep.write_text(FAILING)
    r = esair("run", str(dep), "--mode", mode, "--run", "3", "-e", free_endpoint(), check=False)
    rows = {line.split()[0]: line.split() for line in r.stdout.splitlines()[1:]}
    assert rows["broken"][2] == "failed" and rows["steady"][2] == "running"   # the summary
    assert r.returncode == 1, r.stderr
    assert r.stderr.splitlines()[-1] == ("error: behavior 'broken' failed: "
                                         "RuntimeError: boom"), r.stderr


def _ignoring_sigint():
    signal.signal(signal.SIGINT, signal.SIG_IGN)       # as a shell does for `cmd &`


def _start(*args, **kw):
    return subprocess.Popen([sys.executable, "-m", "esair_min.cli", "std", *args], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=_ignoring_sigint, **kw)


def test_run_and_hmi_started_as_background_jobs_ignore_sigint():
    """Both get a SIGINT. The HMI then serves two page loads one after the other (the
    second after its loop saw the SIGINT); the run gets a SIGTERM: one that took the
    SIGINT exits 130 ("interrupted"), one that kept the ignore stops on the SIGTERM
    alone, status 0 (pending signals are handled in their numbers' order)."""
    import urllib.request
    ep = free_endpoint()
    run = _start("run", "lab", "-e", ep, "--no-top")
    hmi = None
    try:
        wait_for(lambda: run.poll() is not None or esair("ls", "-e", ep, check=False)
                 .returncode == 0, 60, "the robot running")
        assert run.poll() is None, run.communicate()
        hmi = _start("hmi", "-e", ep, "--listen", "127.0.0.1:0")
        url = hmi.stdout.readline().strip()
        assert url.startswith("http://"), hmi.communicate()
        hmi.send_signal(signal.SIGINT)
        for _ in range(2):
            with urllib.request.urlopen(url, timeout=30) as page:
                assert page.status == 200
        assert hmi.poll() is None
        hmi.send_signal(signal.SIGTERM)
        hmi.communicate(timeout=30)
        assert hmi.returncode == 0
        run.send_signal(signal.SIGINT)
        run.send_signal(signal.SIGTERM)
        _, err = run.communicate(timeout=60)
    finally:
        for proc in (run, hmi):
            if proc is not None and proc.poll() is None:
                proc.kill()
                proc.wait(10)
    assert run.returncode == 0, err
    assert "interrupted" not in err


def test_the_signal_helper_keeps_an_ignore_and_installs_otherwise():
    from esair_min import sigs
    code = ("import signal, sys; from esair_min import sigs\n"
            "h = lambda *_: None\n"
            "sigs.install(signal.SIGINT, h)\n"
            "print(signal.getsignal(signal.SIGINT) is h)\n")
    env = dict(os.environ, PYTHONPATH=ROOT)
    kept = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          preexec_fn=_ignoring_sigint, env=env, check=True)
    plain = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           env=env, check=True)
    assert (kept.stdout, plain.stdout) == ("False\n", "True\n")
    assert sigs.ignored(signal.SIGINT) is False                  # pytest's own: a handler


def test_an_agent_started_as_a_background_job_ignores_sigint():
    """SIGINT to the agent, then `esair std remove` from another process (which starts
    long after the SIGINT was handled): the agent leaves because it was removed, not
    because it was interrupted."""
    ep = free_endpoint()
    run = _start("run", "lab", "--mode", "process", "-e", ep, "--no-top")
    agent = None
    try:
        wait_for(lambda: run.poll() is not None or esair("ls", "-e", ep, check=False)
                 .returncode == 0, 60, "the robot running")
        agent = _start("agent", "--connect", ep, "spare", "esair_std.examples.lab.lab:Logger")
        line = agent.stderr.readline()
        assert line.startswith("agent 'spare' joined robot 'lab'"), line + agent.stderr.read()
        agent.send_signal(signal.SIGINT)
        esair("remove", "spare", "-e", ep)
        _, said = agent.communicate(timeout=60)
    finally:
        for proc in (agent, run):
            if proc is not None and proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
                proc.communicate(timeout=60)
    assert said.splitlines()[-1] == "agent 'spare' left robot 'lab': stopped by the control center"
