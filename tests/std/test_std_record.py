"""`esair std record` and `esair std replay` against `esair std run papaman`, both
modes: every feet sample recorded in order (MCAP, JSON schema), and the recording
published again as sensors of the running robot."""

from __future__ import annotations

import json
import signal
import subprocess
import sys

import pytest
from mcap.reader import make_reader

from esair_std.record import SCHEMA, read_samples
from tests.support.std import MODES, esair, free_endpoint, std_run, wait_for


@pytest.mark.parametrize("mode", MODES)
def test_record_then_replay(tmp_path, mode):
    ep = free_endpoint()
    out = tmp_path / "run.mcap"

    def deployed():
        r = esair("ls", "--json", "-e", ep, check=False)
        return r.returncode == 0 and sum(row["state"] in ("running", "ready") for row
                                         in json.loads(r.stdout)["components"]) == 19
    with std_run("papaman", mode, ep, deployed):
        rec = subprocess.Popen([sys.executable, "-m", "esair_min.cli", "std", "record", str(out),
                                "papaman.feet", "-e", ep], stderr=subprocess.PIPE, text=True)
        assert rec.stderr.readline() == f"recording to {out}\n"      # watching from here

        def seq():
            return json.loads(esair("inspect", "papaman.feet", "-e", ep).stdout)["counters"]["seq"]
        first = seq()
        wait_for(lambda: seq() >= first + 5, timeout=30, what="five more feet samples")
        rec.send_signal(signal.SIGTERM)
        assert rec.wait(timeout=30) == 0
        samples = list(read_samples(out))
        assert rec.stderr.read().splitlines()[-1] == (
            f"{out}: {len(samples)} samples on 1 channels, 0 dropped, 0 gaps in seq")
        assert len(samples) >= 5
        assert {s[0] for s in samples} == {"papaman.feet"}
        seqs = [s[1] for s in samples]
        assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))
        assert set(samples[0][3]["groups"]) == {"left_foot", "right_foot"}
        with open(out, "rb") as f:
            summary = make_reader(f).get_summary()
        (schema,) = summary.schemas.values()
        assert (schema.encoding, json.loads(schema.data)) == ("jsonschema", SCHEMA)
        assert [c.message_encoding for c in summary.channels.values()] == ["json"]

        r = subprocess.run([sys.executable, "-m", "esair_min.cli", "plot", str(out), "-o",
                            str(tmp_path / "run.png")], capture_output=True, text=True)
        assert (r.returncode, r.stdout) == (0, f"{len(samples) * 10} samples -> "
                                               f"{tmp_path / 'run.png'}\n")   # 8 values + 2 sums
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
