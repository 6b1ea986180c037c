"""`esair std record` and `esair std replay` against `esair std run papaman`, both
modes: every feet sample recorded in order (MCAP, JSON schema), and the recording
published again as sensors of the running robot."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader

from esair_std.record import COMMAND_SCHEMA, read_commands, read_samples
from tests.support.std import MODES, components, esair, free_endpoint, std_run, wait_for

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("mode", MODES)
def test_record_then_replay(tmp_path, mode):
    ep = free_endpoint()
    out = tmp_path / "run.mcap"

    def deployed():
        return sum(row["state"] in ("running", "ready") for row in components(ep)) == 19
    with std_run("papaman", mode, ep, deployed):
        rec = subprocess.Popen([sys.executable, "-m", "esair_min.cli", "std", "record", str(out),
                                "papaman.feet", "papaman.servo.l_knee", "-e", ep],
                               stderr=subprocess.PIPE, text=True)
        assert rec.stderr.readline() == f"recording to {out}\n"      # watching from here

        def seq():
            return json.loads(esair("inspect", "papaman.feet", "-e", ep).stdout)["counters"]["seq"]
        first = seq()
        wait_for(lambda: seq() >= first + 5, timeout=30, what="five more feet samples")
        # (the recorder's subscriptions are in place: the feet samples reach it)
        sent = [{"angle": 100, "speed": 3}, {"angle": 151}, {"angle": 90, "speed": 3}]
        answers = [esair("send", "papaman.servo.l_knee", json.dumps(c), "-e", ep, check=False)
                   for c in sent]
        assert [a.stdout for a in answers] == ['"odd100"\n', "", '"odd090"\n']
        refusal = ("servo l_knee: angle 151 is outside its limits 0..150 "
                   f"({ROOT / 'boards' / 'papaman' / 'actuator.yaml'}); not sent")

        rec.send_signal(signal.SIGTERM)
        assert rec.wait(timeout=30) == 0
        samples = list(read_samples(out))
        commands = list(read_commands(out))
        with open(out, "rb") as f:
            summary = make_reader(f).get_summary()
        assert rec.stderr.read().splitlines()[-1] == (
            f"{out}: {len(samples)} samples and {len(commands)} commands on 2 channels, "
            "0 dropped, 0 gaps in seq")
        # every command the actuator ran, in order, numbered, stamped, with its outcome
        # (read with the mcap library itself)
        with open(out, "rb") as f:
            rows = [(ch.topic, sc.name, json.loads(m.data), m.log_time, m.sequence)
                    for sc, ch, m in make_reader(f).iter_messages(log_time_order=True)
                    if ch.topic.startswith("command/")]
        assert [(r[0], r[1]) for r in rows] == [("command/papaman.servo.l_knee",
                                                 "esair.Command")] * 3
        assert [{k: v for k, v in r[2].items() if k not in ("seq", "t")} for r in rows] == [
            {"command": sent[0], "ok": "odd100", "by": "operator"},
            {"command": sent[1], "error": refusal, "by": "operator"},
            {"command": sent[2], "ok": "odd090", "by": "operator"}]
        seqs = [r[2]["seq"] for r in rows]
        assert seqs == list(range(seqs[0], seqs[0] + 3)) and [r[4] for r in rows] == seqs
        assert [r[3] for r in rows] == sorted(r[3] for r in rows)
        assert [r[3] for r in rows] == [int(r[2]["t"] * 1e9) for r in rows]
        assert samples[0][2] - 30 < rows[0][2]["t"] < samples[-1][2] + 30
        assert len(samples) >= 5
        assert {s[0] for s in samples} == {"papaman.feet"}
        seqs = [s[1] for s in samples]
        assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))
        assert set(samples[0][3]["groups"]) == {"left_foot", "right_foot"}
        schemas = {s.name: s for s in summary.schemas.values()}
        assert json.loads(schemas["esair.Command"].data) == COMMAND_SCHEMA
        feet = json.loads(schemas["esair.Sample.papaman.feet"].data)     # its fields, named
        assert set(feet["properties"]["value"]["properties"]["values"]["properties"]) == {
            f"{s}_{p}_{q}" for s in "lr" for p in ("toe", "heel") for q in ("in", "out")}
        topics = {c.topic: c.message_encoding for c in summary.channels.values()}
        assert {t: e for t, e in topics.items() if not t.startswith("/")} == {
            "papaman.feet": "json", "command/papaman.servo.l_knee": "json"}
        assert topics["/papaman/joints"] == "json" and topics["/log"] == "protobuf"

        r = subprocess.run([sys.executable, "-m", "esair_min.cli", "plot", str(out), "-o",
                            str(tmp_path / "run.png")], capture_output=True, text=True)
        assert (r.returncode, r.stdout) == (0, f"{len(samples)} samples ({len(samples) * 10} values) "
                                               f"-> {tmp_path / 'run.png'}\n")   # 8 values + 2 sums
        assert (tmp_path / "run.png").read_bytes()[:4] == b"\x89PNG"

        assert esair("replay", str(out), "-e", ep, "--speed", "4").stdout == (
            "replay.papaman.feet: sensor ready\n")

        def reported():
            info = json.loads(esair("inspect", "replay.papaman.feet", "-e", ep).stdout)
            return info["counters"]["reported"] == len(samples)
        wait_for(reported, timeout=20, what="every recorded sample replayed")


def test_a_file_that_is_not_mcap_is_refused(tmp_path):
    bad = tmp_path / "bad.mcap"
    bad.write_text("not mcap")
    with pytest.raises(Exception) as exc:
        list(read_samples(bad))
    assert str(exc.value).startswith(f"{bad} is not a readable MCAP file: ")
