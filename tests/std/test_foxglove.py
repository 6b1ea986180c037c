"""Foxglove (docs/foxglove.md): ``esair std run ROBOT --foxglove`` serves the Foxglove
WebSocket protocol, and ``esair std record`` writes the same channels to MCAP. Against
running STARFISH and PAPA-MAN in both modes, a protocol client (tests/support/
foxclient.py) subscribes to every channel and each message is decoded against its
schema (Foxglove's own JSON Schemas for its types: tests/support/foxcheck.py), a
recording made meanwhile is read back with the ``mcap`` library and checked the same
way; the pictures decode with Pillow; commands go through the RS as the operator, only
where the deployment grants it; a foreign Origin is refused."""

from __future__ import annotations

import io
import json
import re
import struct
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer
from PIL import Image
from websockets.exceptions import InvalidStatus

from esair_std.drivers.minlink.emulated import EmulatedRobot
from esair_std.record import SCHEMA, read_samples
from esair_std.record.recorder import Recorder
from tests.support.foxcheck import decode
from tests.support.scenarios import push_soon
from bench.toolkit.foxclient import FoxClient
from tests.support.hmi import PAPAMAN, ROOT, HmiRun, free_port, wait_for

pytestmark = pytest.mark.slow

STARFISH = {"starfish.odometry", "starfish.mics", "starfish.radio", "starfish.map",
            "starfish.pictures", "/starfish/pose", "/tf", "/starfish/scene", "/starfish/camera",
            "/starfish/mics/levels", "command/starfish.wheels", "command/starfish.camera",
            "/log", "/link", "latch"}
PAPA = {"papaman.feet", "papaman.notices", "/papaman/reactions", "/papaman/joints",
        "command/papaman.servo.l_knee", "/log", "/link", "latch"}


class FoxRun(HmiRun):
    """``esair std run ROBOT --foxglove`` on a free port; PAPA-MAN on its own emulated
    robot (restarted with a push scenario while the client looks)."""

    def __init__(self, robot: str, mode: str, tmp: Path):
        self.robot = robot
        self.emu = EmulatedRobot(PAPAMAN, []) if robot == "papaman" else None
        super().__init__(mode, tmp, [robot])

    def start(self) -> FoxRun:
        args = [self.robot] + (["--port", self.emu.start()] if self.emu else [])
        self.errors = open(self.tmp / "run.err", "w+")      # noqa: SIM115 - closed in stop()
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "esair_min.cli", "std", "run", *args, "--foxglove",
             "--foxglove-listen", "127.0.0.1:0", "--mode", self.mode, "-e", self.endpoint,
             "--no-top"], stdout=subprocess.DEVNULL, stderr=self.errors, env=self.env(),
            cwd=self.tmp)

        def url():
            if self.proc.poll() is not None:
                raise AssertionError(f"esair std run exited: {(self.tmp / 'run.err').read_text()}")
            m = re.search(r"^foxglove: (ws://\S+)$", (self.tmp / "run.err").read_text(), re.M)
            return m and m.group(1)
        self.url = wait_for(url, timeout=90, what="the Foxglove server's URL")
        return self

    def stop(self) -> None:
        super().stop()
        if self.emu is not None:
            self.emu.stop()


@pytest.fixture(scope="module", params=[(r, m) for r in ("starfish", "papaman")
                                        for m in ("thread", "process")],
                ids=lambda p: "-".join(p))
def live(request, tmp_path_factory):
    robot, mode = request.param
    r = FoxRun(robot, mode, tmp_path_factory.mktemp(f"fox-{robot}-{mode}"))
    try:
        yield r.start()
    finally:
        r.stop()
    assert r.proc.returncode == 0, (r.tmp / "run.err").read_text()


def by_topic(client: FoxClient) -> dict[str, list[bytes]]:
    out: dict[str, list[bytes]] = defaultdict(list)
    for topic, _ns, data, _rx in client.got:
        out[topic].append(data)
    return out


def check_all(schemas: dict[str, object], msgs: dict[str, list[bytes]]) -> dict[str, list[dict]]:
    """Every message decoded against its channel's schema (raises on the first wrong)."""
    return {topic: [decode(schemas[topic], d) for d in datas] for topic, datas in msgs.items()}


def check_content(robot: str, got: dict[str, list[dict]], raw: dict[str, list[bytes]]) -> None:
    if robot == "starfish":
        pics = [Image.open(io.BytesIO(d)) for d in raw_images(raw)]
        assert pics and all(p.size == (320, 240) for p in pics)
        assert all(np.asarray(p.convert("L")).std() > 5 for p in pics)     # a scene, not blank
        rooms = [e for u in got["/starfish/scene"] for e in u["entities"] if e["id"] == "room"]
        assert len(rooms[-1]["lines"][0]["points"]) == 10          # 5 walls
        assert len(rooms[-1]["cylinders"]) == 3 and len(rooms[-1]["spheres"]) == 2  # AP, sound
        arrows = [e for u in got["/starfish/scene"] for e in u["entities"]
                  if e["frame_id"] == "base_link" and e["arrows"]]
        assert arrows, "the localizer's bearing as an arrow"
        assert got["/tf"][-1]["child_frame_id"] == "base_link"
        assert set(got["/starfish/mics/levels"][-1]) == {"mic0", "mic1", "mic2", "mic3"}
    else:
        assert got["/papaman/reactions"][0]["reaction"] == "auto_balance"
        assert got["/papaman/joints"][-1]["l_knee"] == 100
        knee = got["command/papaman.servo.l_knee"][0]        # with its sender and result
        assert (knee["command"], knee["ok"], knee["by"]) == ({"angle": 100, "speed": 3},
                                                             "odd100", "operator")
        assert set(got["papaman.feet"][-1]["value"]["values"]) == {
            f"{s}_{p}_{q}" for s in "lr" for p in ("toe", "heel") for q in ("in", "out")}


def raw_images(raw: dict[str, list[bytes]]) -> list[bytes]:
    from tests.support.foxcheck import _message_class
    from esair_std.record.foxmsgs import IMAGE
    cls = _message_class(IMAGE.name, IMAGE.data)
    return [cls.FromString(d).data for d in raw["/starfish/camera"]]


def test_every_channel_live_and_recorded_decodes_against_its_schema(live, tmp_path):
    robot = live.robot
    client = FoxClient(live.url)
    rec = Recorder(live.endpoint, str(tmp_path / "run.mcap"))
    rec.start()
    try:
        want = STARFISH if robot == "starfish" else PAPA
        if robot == "starfish":
            live.std("configure", "starfish.mics", "source", '{"x": 1.0, "y": 3.5, "on": true}')
        else:
            client.wait_ready()
            assert client.call("command", {"resource": "papaman.servo.l_knee",
                                           "command": {"angle": 100, "speed": 3}}) == (True, "odd100")
            # the robot pulled and plugged back (the link's channel), its push held
            # until the link is up again (it reconnects with a backoff)
            live.emu.kill()
            live.emu.start(["--scenario", str(push_soon(tmp_path)), "--hold-scenario"])
        pushed = [0.0]

        def everything():
            client.pump(0.3)
            got = by_topic(client)
            links = [json.loads(d)["state"] for d in got["/link"]]
            if (robot == "papaman" and "/papaman/reactions" not in got and "lost" in links
                    and links[-1] == "ready" and time.monotonic() - pushed[0] > 3.0):
                live.emu.play_scenario()       # the push: again if its reaction is not seen
                pushed[0] = time.monotonic()
            return want <= set(got)
        wait_for(everything, timeout=90, what=lambda: f"every channel of {robot}: "
                 f"{sorted(want - set(by_topic(client)))} missing")
        if robot == "starfish":       # the bearing's arrow: once localize is confident
            wait_for(lambda: client.pump(0.3) or any(
                b"base_link" in d for d in by_topic(client)["/starfish/scene"]),
                timeout=60, what="the bearing on the scene")
    finally:
        rec.stop()
        client.close()
    schemas = {c.topic: type("S", (), {"name": c.name, "encoding": c.encoding, "data": c.data})
               for c in client.channels.values()}
    raw = by_topic(client)
    check_content(robot, check_all(schemas, raw), raw)

    # the recording: the same channels, every message valid, read with the mcap library
    recorded: dict[str, list[bytes]] = defaultdict(list)
    with open(tmp_path / "run.mcap", "rb") as f:
        reader = make_reader(f)
        rschemas = {}
        for schema, channel, message in reader.iter_messages():
            rschemas[channel.topic] = schema
            recorded[channel.topic].append(message.data)
    assert want - {"latch"} <= set(recorded)     # (the latch: recorded when STOPPED)
    check_content(robot, check_all(rschemas, recorded), recorded)
    live_schemas = {c.topic: (c.name, c.encoding) for c in client.channels.values()}
    assert {t: (s.name, s.encoding) for t, s in rschemas.items() if t in live_schemas} == {
        t: s for t, s in live_schemas.items() if t in rschemas}


def test_commands_only_where_the_operator_is_granted(live):
    client = FoxClient(live.url)
    try:
        client.wait_ready()
        if live.robot == "starfish":             # allow: {"*": read, patrol, turn_and_shoot}
            ok, why = client.call("command", {"resource": "starfish.wheels",
                                              "command": {"vx": 0, "vy": 0, "w": 0}})
            assert not ok and "'operator' up to read, not command" in why
            return
        ok, state = client.call("stop", {"reason": "from foxglove"})
        assert ok and state["by"] == "foxglove"
        ok, why = client.call("command", {"resource": "papaman.servo.l_knee",
                                          "command": {"angle": 90}})
        assert not ok and "stopped by foxglove" in why
        assert client.call("release", {})[0]
        ok, answer = client.call("command", {"resource": "papaman.servo.l_knee",
                                             "command": {"angle": 90}})
        assert ok and answer.endswith("090")     # the servo's reply to the angle
    finally:
        client.close()


def test_client_publish_commands_only_where_the_operator_is_granted(live):
    """Client publish (``/esair/command``, ``/esair/stop``, ``/esair/release``): through
    the RS as the services, the answer as a status message."""
    client = FoxClient(live.url)
    try:
        client.wait_ready()
        assert "clientPublish" in client.info["capabilities"]
        assert set(json.loads(client.info["metadata"]["clientPublish"])) == {
            "/esair/command", "/esair/stop", "/esair/release"}
        if live.robot == "starfish":
            level, why = client.publish("/esair/command", {"resource": "starfish.wheels",
                                                           "command": {"vx": 0, "vy": 0, "w": 0}})
            assert level == 2 and "'operator' up to read, not command" in why
            return
        # a joint angle: the servo's reply, the command's record (by the operator) and
        # the joints' channel show it
        level, said = client.publish("/esair/command", {"resource": "papaman.servo.l_knee",
                                                        "command": {"angle": 95}})
        assert level == 0 and said.startswith("/esair/command: ") and said.endswith('095"'), said
        wait_for(lambda: client.pump(0.2) or any(
            json.loads(d)["command"] == {"angle": 95} and json.loads(d)["by"] == "operator"
            for d in by_topic(client)["command/papaman.servo.l_knee"]),
            timeout=30, what="the command's record")
        wait_for(lambda: client.pump(0.2) or json.loads(by_topic(client)["/papaman/joints"][-1])[
            "l_knee"] == 95, timeout=30, what="the joint at 95 degrees")
        # a motion, the STOP (a command refused), the release
        assert client.publish("/esair/command", {"resource": "papaman.motion",
                                                 "command": "stand"}) == (0, '/esair/command: "t"')
        level, said = client.publish("/esair/stop", {"reason": "by client publish"})
        assert level == 0 and '"by": "foxglove"' in said
        level, why = client.publish("/esair/command", {"resource": "papaman.servo.l_knee",
                                                       "command": {"angle": 90}})
        assert level == 2 and "stopped by foxglove" in why
        assert client.publish("/esair/release", {})[0] == 0
        assert client.publish("/esair/command", {"resource": "papaman.servo.l_knee",
                                                 "command": {"angle": 90}})[0] == 0
    finally:
        client.close()


def test_garbage_frames_get_an_error_status_and_lose_nothing(live):
    """Each frame the protocol does not know gets an error status; the client stays
    connected and its subscriptions lose no sample meanwhile."""
    sensor = "starfish.odometry" if live.robot == "starfish" else "papaman.feet"
    client = FoxClient(live.url)
    try:
        wait_for(lambda: client.pump(0.2) or len(by_topic(client)[sensor]) >= 2,
                 timeout=30, what=f"{sensor}'s samples")
        garbage: list[str | bytes] = [
            b"", b"\x07abc", b"\x02\x00\x00",         # no opcode, an unknown one, too short
            b"\x01\x63\x00\x00\x00{}",               # on a client channel not advertised
            "not json", '{"op": "nonsense"}', '{"no": "op"}',
            json.dumps({"op": "advertise", "channels": [{"id": 7, "topic": "/elsewhere",
                                                         "encoding": "json", "schemaName": "x"}]}),
            json.dumps({"op": "advertise", "channels": [{"id": 8, "topic": "/esair/command",
                                                         "encoding": "cdr", "schemaName": "x"}]}),
            json.dumps({"op": "subscribe", "subscriptions": [{"id": "x"}]})]
        for frame in garbage:
            level, message = client.send_expecting_status(frame)
            assert level == 2 and message.startswith("bad request: ") or (
                level == 2 and "not advertised" in message), (frame, message)
        cid = client.advertise("/esair/command")
        level, message = client.send_expecting_status(struct.pack("<BI", 1, cid) + b"[1, 2")
        assert level == 2 and "not JSON" in message
        before = len(by_topic(client)[sensor])
        wait_for(lambda: client.pump(0.2) or len(by_topic(client)[sensor]) >= before + 4,
                 timeout=30, what=f"{sensor}'s samples after the garbage")
        seqs = [json.loads(d)["seq"] for d in by_topic(client)[sensor]]
        assert len(seqs) >= 4 and seqs == list(range(seqs[0], seqs[0] + len(seqs))), seqs
    finally:
        client.close()


LAYOUT = json.loads((ROOT / "docs" / "foxglove-layout.json").read_text())
GENERIC = {"/log", "/tf"}                        # every robot's


def layout_refs() -> list[tuple[str, str, str]]:
    """What docs/foxglove-layout.json shows: (panel, topic, message path or "")."""
    refs = []
    for panel, cfg in LAYOUT["configById"].items():
        for topic in cfg.get("topics", {}):
            refs.append((panel, topic, ""))
        if "imageMode" in cfg:
            refs.append((panel, cfg["imageMode"]["imageTopic"], ""))
        if "topicToRender" in cfg:
            refs.append((panel, cfg["topicToRender"], ""))
        for path in cfg.get("paths", []):
            m = re.fullmatch(r'"([^"]+)"\.(.+)|(/[^.]+)\.(.+)', path["value"])
            assert m, path
            refs.append((panel, m.group(1) or m.group(3), m.group(2) or m.group(4)))
    return refs


def test_the_layout_names_only_what_a_robot_publishes(live):
    """No viewer runs here: the layout's panels are checked against the channels the
    live server advertises (their schemas fit the panel) and each plotted path against
    a message of its channel (the recording has the same channels: the first test)."""
    refs = layout_refs()
    assert {t for _p, t, _f in refs} - GENERIC <= {t for _p, t, _f in refs
                                                   if "starfish" in t or "papaman" in t}
    mine = [(p, t, f) for p, t, f in refs if t in GENERIC or live.robot in t]
    client = FoxClient(live.url)
    try:
        client.wait_ready()
        if live.robot == "starfish":
            live.std("configure", "starfish.mics", "source", '{"x": 1.0, "y": 3.5, "on": true}')
        else:
            for joint in {f for _p, t, f in mine if t == "/papaman/joints"}:
                # (again while the pushes' reactions or the load make one fail)
                end = time.monotonic() + 60
                while not (said := client.call("command", {"resource": f"papaman.servo.{joint}",
                                                           "command": {"angle": 90}}))[0]:
                    assert time.monotonic() < end, (joint, said)
        want = {t for _p, t, _f in mine}
        wait_for(lambda: client.pump(0.3) or want <= set(by_topic(client)), timeout=90,
                 what=f"{sorted(want - set(by_topic(client)))} of the layout")
    finally:
        client.close()
    schema = {c.topic: c.name for c in client.channels.values()}
    fits = {"3D": {"foxglove.SceneUpdate", "foxglove.PoseInFrame"},
            "Image": {"foxglove.CompressedImage"}, "RosOut": {"foxglove.Log"}}
    for panel, topic, path in mine:
        kind = panel.split("!")[0]
        if kind in fits:
            assert schema[topic] in fits[kind], (panel, topic, schema[topic])
            continue
        msg = json.loads(by_topic(client)[topic][-1])
        for key in path.split("."):
            msg = msg[key]
        assert isinstance(msg, (int, float)), (panel, topic, path, msg)
    if live.robot == "starfish":                # the 3-D panel follows the robot's frame
        follow = LAYOUT["configById"]["3D!room"]["followTf"]
        tf = check_all({"/tf": next(c for c in client.channels.values() if c.topic == "/tf")},
                       {"/tf": by_topic(client)["/tf"][-1:]})
        assert tf["/tf"][0]["child_frame_id"] == follow


def test_a_foreign_origin_is_refused(live):
    with pytest.raises(InvalidStatus) as exc:
        FoxClient(live.url, origin="https://evil.example")
    assert exc.value.response.status_code == 403
    FoxClient(live.url).close()                  # a native app sends no Origin


def test_other_addresses_are_refused_without_client_certificates():
    r = subprocess.run([sys.executable, "-m", "esair_min.cli", "std", "foxglove", "--listen",
                        f"0.0.0.0:{free_port()}", "-e", "tcp/127.0.0.1:1"],
                       capture_output=True, text=True, cwd=ROOT, timeout=60)
    assert r.returncode == 1
    assert r.stderr.strip().endswith("listening on 0.0.0.0 reaches other computers: it needs "
                                     "client certificates (--tls-cert, --tls-key, --client-ca) "
                                     "or an SSH tunnel to 127.0.0.1, or --insecure to go without")


def test_recordings_of_before_read_as_ever(tmp_path):
    """A file of the old format (one schema ``esair.Sample``, untyped value)."""
    path = tmp_path / "old.mcap"
    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="", library="esair")
        sid = w.register_schema(name="esair.Sample", encoding="jsonschema",
                                data=json.dumps(SCHEMA).encode())
        ch = w.register_channel(topic="papaman.feet", message_encoding="json", schema_id=sid)
        for seq in (1, 2):
            w.add_message(channel_id=ch, log_time=seq, publish_time=seq, sequence=seq,
                          data=json.dumps({"seq": seq, "t": seq / 1e9, "value": {"n": seq}}).encode())
        w.finish()
    assert list(read_samples(path)) == [("papaman.feet", 1, 1e-9, {"n": 1}),
                                        ("papaman.feet", 2, 2e-9, {"n": 2})]
