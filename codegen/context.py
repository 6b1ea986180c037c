"""The template context of each board: every number the C needs, computed here.

Templates loop over these values and copy them; they compute nothing. The context of
a board is a plain dict of str/int/bytes/lists of dicts, built from the frozen model
(and esair_min.model.hardware, layout, image, protocol) only.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from esair_min import __version__
from esair_min.components import motion, pressure_sensor, servo
from esair_min.core import protocol as P
from esair_min.errors import GenerateError
from esair_min.model.encoding import MAX_LINE
from esair_min.model.hardware import BaudSetting, I2cSetting, Timer2Setting
from esair_min.model import picboot
from esair_min.core.image import build_image
from esair_min.components.motion.layout import HEADER_BYTES, VERSION
from esair_min.model.board import Board
from esair_min.model.robot import Robot

from . import filters, ports, timing

Context = dict[str, Any]

#: Bytes per EEPROM read while checking the image at reset (docs/protocol.md, Reset).
IMAGE_CHECK_CHUNK = 32
#: CMD_LEN of a variable-length row (image_write): its shortest length with this bit set.
VARIABLE_LEN = 0x80
#: Servo pulse ends closer than this are handled by one PWM interrupt.
PWM_MERGE_US = 16
#: ADC acquisition time before a conversion (datasheet: 12.86 us at 25 C; rounded up).
ADC_ACQ_US = 15
#: SDCC's software stack on the PIC: 128 bytes inside bank 2 (it must not cross a bank).
PIC_STACK = {"bottom": 0x280, "size": 128}
PORTS = "ABCDE"
#: The central core's scalars live in the PIC's access bank from here (below it: the
#: compiler's .registers; up to 0x7F: ours). gplink fails the build if they overlap.
PIC_NEAR_BASE = 0x20


def common_context(robot: Robot, board: Board) -> Context:
    """Banner and MCU facts shared by every board."""
    source = f"{robot.name}/{Path(robot.file_of(board)).name}"
    return {
        "version": __version__,
        "source": source,
        "robot": robot.name,
        "board": board.board,
        "role": board.role,
        "clock_hz": board.mcu.clock_hz,
        "oscillator": timing.oscillator(board.mcu.clock_hz),
        "sync_pin": _pin(board.sync.pin) if board.sync else None,
        "pic_stack": PIC_STACK,
        "boot": picboot.boot_context(robot.name, board.role, board.mcu.clock_hz),
        **ports.mcu_context(board),
    }


def _pin(name: str) -> dict[str, Any]:
    """``RB0`` -> port letter, port index 0..4 and bit mask."""
    port, bit = name[1], int(name[2])
    return {"name": name, "port": port, "index": PORTS.index(port), "bit": bit,
            "mask": 1 << bit}


def _split_image_ok(line: bytes) -> tuple[bytes, bytes]:
    """A line made with ``image_ok=True`` (CRC 0) split around its ``ok crc=0000`` (the
    C core sends ``ok crc=`` and the CRC, or ``bad``, between the two parts)."""
    before, sep, after = line.partition(b"image=ok crc=0000")
    assert sep, line
    return before + b"image=", after


#: The build id a context is rendered with before its sources are hashed (codegen.buildid).
BUILD_PLACEHOLDER = "00000000"


def central_context(robot: Robot, build_id: str = BUILD_PLACEHOLDER) -> Context:
    """The central board's context: one piece per feature, each from the model only.
    ``build_id``: the firmware's id in its replies (codegen.buildid computes it)."""
    board = robot.central
    ctx = common_context(robot, board)
    servos = robot.servos
    commands = _command_context(robot)
    motions = _motion_context(robot)
    reactions = _reaction_context(robot)
    texts = _texts(*_fixed_texts(robot, build_id), reactions["reactions"])
    if board.spec.family == "avr":
        ctx["avr"] = ports.central_avr(board)
    ctx.update({
        "servos": servo.limit_rows(servos),
        "n_servos": len(servos),
        "frame_bytes": 2 * len(servos),
        "n_sensors": len(robot.sensors),
        **commands, **motions, **reactions, **_peer_context(robot),
        "texts": texts,
        "rom": _rom(commands["commands"], servo.limit_rows(servos),
                    reactions["reactions"], commands["prefix_pool"], texts),
        "near_base": PIC_NEAR_BASE,
        "text_pool_bytes": sum(len(t["text"]) + 1 for t in texts),
        **_clock_context(board, P.TX_RING_TABLE),
    })
    return ctx


def _command_context(robot: Robot) -> Context:
    """The command table: prefixes in one shared pool, one row per command."""
    uart = robot.central.uart
    n = len(robot.servos)
    numbers = {m.name: m.number for m in robot.motions}
    pool = bytearray()
    rows = []
    for c in robot.commands:
        at = pool.find(c.prefix.encode("ascii"))
        if at < 0:
            at = len(pool)
            pool += c.prefix.encode("ascii")
        length = c.length(n)
        if length > MAX_LINE:
            raise GenerateError(f"command '{c.name}' needs {length} characters, more than "
                                f"the {MAX_LINE} of a line")
        if c.variable and len(c.prefix) < 1:
            raise GenerateError(f"command '{c.name}' needs a prefix")
        rows.append({"name": c.name, "at": at, "prefix_len": len(c.prefix), "length": length,
                     "len_code": length | (VARIABLE_LEN if c.variable else 0),
                     "action": c.action.upper(),
                     "motion": numbers[c.motion] if c.motion else 0xFF})
    return {
        "require_checksum": int(bool(uart and uart.require_checksum)),
        "line_max": MAX_LINE,
        "prefix_pool": bytes(pool),
        "commands": rows,
        "actions": [{"name": a, "code": i} for i, a in enumerate(ACTIONS)],
        "busy_last": BUSY_ACTIONS - 1,
    }


def _motion_context(robot: Robot) -> Context:
    """The EEPROM the image lives in, and the image the board files build (the host
    port's EEPROM holds it; the firmware accepts any image that checks)."""
    eeprom = robot.eeprom
    image = build_image(robot) if eeprom is not None else b""
    if eeprom is not None and eeprom.page_bytes & (eeprom.page_bytes - 1):
        raise GenerateError(f"EEPROM '{eeprom.name}': page_bytes {eeprom.page_bytes} is not "
                            "a power of two")
    write_max = max((MAX_LINE - len(c.prefix)) // 2 for c in robot.commands
                    if c.action == "image_write") if any(
        c.action == "image_write" for c in robot.commands) else 0
    return {
        "motions": motion.directory_rows(robot.layout.slots),
        "has_eeprom": int(eeprom is not None),
        "eeprom": ({"address": eeprom.address, "address_bytes": eeprom.address_bytes,
                    "size": eeprom.size_bytes, "page": eeprom.page_bytes} if eeprom else
                   {"address": 0, "address_bytes": 2, "size": 0, "page": 1}),
        "image": image,
        "image_version": VERSION,
        "image_length": len(image),
        "image_crc": int.from_bytes(image[6:8], "little") if image else 0xFFFF,
        "image_chunk": IMAGE_CHECK_CHUNK,
        # the line's hex pairs of a write (address, data, checksum) or a read's data
        "buf_bytes": max(2 * len(robot.servos), HEADER_BYTES, P.READ_MAX, write_max, 1),
        "read_max": P.READ_MAX, "poll_max": P.POLL_MAX,
        "scan_first": P.SCAN_FIRST, "scan_last": P.SCAN_LAST,
    }


def _reaction_context(robot: Robot) -> Context:
    """The reactions and the sensor groups they compare (as bit masks)."""
    numbers = {m.name: m.number for m in robot.motions}
    groups: list[str] = []
    reactions: list[dict[str, Any]] = []
    for r in robot.central.reactions:
        for g in r.compare:
            if g not in groups:
                groups.append(g)
        reactions.append({"name": r.name, "group_a": groups.index(r.compare[0]),
                          "group_b": groups.index(r.compare[1]), "threshold": r.threshold,
                          "samples": r.samples, "poll_ticks": r.poll_ticks,
                          "motion": numbers[r.motion],
                          "notice": P.reaction_line(r.name),
                          "held_notice": P.held_reaction_line(r.name)})
    group_masks = [{"name": g, "mask": pressure_sensor.group_mask(robot.sensors, g)}
                   for g in groups]
    for r in reactions:
        r["mask_a"] = group_masks[r["group_a"]]["mask"]
        r["mask_b"] = group_masks[r["group_b"]]["mask"]
    return {"groups": group_masks, "reactions": reactions}


def _peer_context(robot: Robot) -> Context:
    """Where the peer boards answer on the bus."""
    def peer(role: str) -> dict[str, int]:
        dev = robot.peer(role)
        return {"present": int(dev is not None), "address": dev.address if dev else 0,
                "registers": dev.registers if dev else 0}

    return {"actuator": peer("actuator"), "sensor": peer("sensor")}


def _fixed_texts(robot: Robot, build_id: str) -> tuple[bytes, bytes, bytes, bytes]:
    """The version reply and the READY notice, each split around its image state."""
    uart = robot.central.uart
    checksum = bool(uart and uart.require_checksum)
    ver_pre, ver_post = _split_image_ok(P.ok_line(P.version_data(
        len(robot.servos), len(robot.sensors), len(robot.motions), True, checksum,
        build=build_id)))
    ready_pre, ready_post = _split_image_ok(P.ready_line(True, build=build_id))
    return ver_pre, ver_post, ready_pre, ready_post


def _clock_context(board: Board, tx_ring: int = P.TX_RING) -> Context:
    """Timer2, the baud divisor, the I2C master's SSPADD and the UART rings."""
    t2, baud, i2c = board.timer2, board.baud, board.i2c_setting
    if t2 is None or baud is None or i2c is None:
        raise GenerateError(f"central board '{board.board}' needs tick:, uart: and an "
                            f"I2C master")
    uart = board.uart
    rings = {"rx_ring": P.RX_RING, "tx_ring": tx_ring}
    if board.spec.family != "pic18":
        return rings                     # the PIC18F452's register values only on that part
    assert (isinstance(t2, Timer2Setting) and isinstance(baud, BaudSetting)
            and isinstance(i2c, I2cSetting))
    return {
        **rings,
        "timer2": {"t2con": t2.t2con, "pr2": t2.pr2, "prescale": t2.prescale,
                   "postscale": t2.postscale, "period_us": round(t2.period_s * 1e6, 1)},
        "baud": {"spbrg": baud.spbrg, "brgh": baud.brgh, "rate": uart.baud if uart else 0,
                 "error_percent": round(baud.error_percent, 2)},
        "i2c": {"sspadd": i2c.sspadd, "speed_hz": board.i2c.speed_hz},
    }


def _texts(ver_pre: bytes, ver_post: bytes, ready_pre: bytes, ready_post: bytes,
           reactions: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Every text the central core sends, in one NUL-separated pool (es_text): the
    error line of code c is text c (text 0 is empty); a notice is ``!`` then the error
    line (esair_min.core.protocol builds NOTICE_LINE so); the reactions' notices last, each
    reaction's ``!R`` followed by its ``!H`` (the core sends text RE_TEXT + held)."""
    codes = sorted(P.Code)
    assert [int(c) for c in codes] == list(range(1, len(codes) + 1)), codes
    assert all(P.NOTICE_LINE[c] == b"!" + P.ERROR_LINE[c] for c in codes)
    items = [("NONE", b"")] + [(f"E{int(c):02d}", P.ERROR_LINE[c]) for c in codes]
    items += [("BANG", b"!"), ("OK", P.OK_LINE), ("OK_SP", b"OK "), ("CRLF", b"\r\n"),
              ("IMG_OK", b"ok crc="), ("IMG_BAD", b"bad"),
              ("VERSION_PRE", ver_pre), ("VERSION_POST", ver_post),
              ("READY_PRE", ready_pre), ("READY_POST", ready_post)]
    for r in reactions:
        items += [(f"R_{r['name'].upper()}", r["notice"]),
                  (f"H_{r['name'].upper()}", r["held_notice"])]
    texts, at = [], 0
    for i, (name, text) in enumerate(items):
        assert b"*/" not in text and b"\0" not in text, text   # shown in a C comment
        texts.append({"id": i, "name": name, "text": text, "data": text + b"\0", "at": at})
        at += len(text) + 1
    for r, t in zip(reactions, texts[len(texts) - 2 * len(reactions)::2], strict=True):
        r["text_id"] = t["id"]
    return texts


#: Command actions in the order of their ES_ACT_* codes: the four refused while a
#: motion plays first (the core tests ``action <= ES_ACT_BUSY_LAST``).
ACTIONS = ("STAND", "MOTOR", "PLAY", "ANGLES", "IMAGE_WRITE", "IMAGE_READ", "IMAGE_COMMIT",
           "SPEEDS", "VERSION", "SENSORS", "STOP", "I2C_SCAN", "HOLD")
BUSY_ACTIONS = 7


def _u16(values: list[int]) -> bytes:
    return b"".join(v.to_bytes(2, "little") for v in values)


def _rom(commands: list[dict[str, Any]], servos: list[dict[str, Any]],
         reactions: list[dict[str, Any]], prefix_pool: bytes,
         texts: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Every table of the central core as sections of one byte array (es_rom), columns
    indexed by row, 16-bit values little-endian: the core reads flash through one
    function. Each section: name (ES_R_<name>), at, what, lines of C initialiser."""
    def col(rows: list[dict[str, Any]], key: str) -> bytes:
        return bytes(r[key] for r in rows)

    parts: list[tuple[str, str, list[bytes]]] = [
        ("PREFIX", "command prefixes, shared where one is part of another", [prefix_pool]),
        ("CMD_AT", "command rows: first prefix byte in ES_R_PREFIX", [col(commands, "at")]),
        ("CMD_PLEN", "prefix length", [col(commands, "prefix_len")]),
        ("CMD_LEN", "characters of a matching line, checksum excluded (bit 7: or more)",
         [col(commands, "len_code")]),
        ("CMD_ACTION", "ES_ACT_*: " + " ".join(c["action"] for c in commands),
         [bytes(ACTIONS.index(c["action"]) for c in commands)]),
        ("CMD_MOTION", "fixed motion number, 0xFF: none", [col(commands, "motion")]),
        ("LIM_MIN", "servos: minimum angle (16 bits)", [_u16([s["min"] for s in servos])]),
        ("LIM_MAX", "maximum angle (16 bits)", [_u16([s["max"] for s in servos])]),
        ("STAND", "stand pose (16 bits)", [_u16([s["stand"] for s in servos])]),
        ("SPEED", "speed code after reset", [col(servos, "speed")]),
        ("RE_MASK_A", "reactions: sensors of the first group (bit i = sensor i)",
         [col(reactions, "mask_a")]),
        ("RE_MASK_B", "sensors of the second group", [col(reactions, "mask_b")]),
        ("RE_THRESHOLD", "threshold (16 bits)", [_u16([r["threshold"] for r in reactions])]),
        ("RE_SAMPLES", "samples", [col(reactions, "samples")]),
        ("RE_POLL", "poll ticks", [col(reactions, "poll_ticks")]),
        ("RE_MOTION", "motion (its number)", [col(reactions, "motion")]),
        ("RE_TEXT", "notice (text id; its held notice is the next)",
         [col(reactions, "text_id")]),
        ("TEXT_AT", "where each text starts in ES_R_TEXT (16 bits)",
         [_u16([t["at"] for t in texts])]),
        ("TEXT", "every text sent, NUL-terminated; a notice is ! then the error line",
         [t["data"] for t in texts]),
    ]
    out, at = [], 0
    for name, what, chunks in parts:
        lines = []
        for chunk, t in zip(chunks, texts if name == "TEXT" else [None] * len(chunks)):
            if t is not None:
                lines.append(f"/* {t['id']} {t['name']} {filters.c_string(t['text'])} */")
            if chunk:
                lines += filters.c_bytes(chunk, 12, "").split("\n")
        size = sum(len(c) for c in chunks)
        out.append({"name": name, "at": at, "what": what, "size": size,
                    "lines": [ln.rstrip(",") + "," if not ln.startswith("/*") else ln
                              for ln in lines]})
        at += size
    if at > 0xFFFF:
        raise GenerateError(f"the central board's tables need {at} bytes, more than 65535")
    return out


def actuator_context(robot: Robot) -> Context:
    board = robot.actuator
    assert board is not None
    ctx = common_context(robot, board)
    sync = ctx["sync_pin"]
    want = board.spec.sync_input
    if sync is None or sync["name"] != want:
        raise GenerateError(f"actuator board '{board.board}': the sync pin must be {want} "
                            f"(INT0), not {sync['name'] if sync else 'missing'}")
    avr_port = ports.actuator_avr(board) if board.spec.family == "avr" else None
    if avr_port is not None:
        pwm_ctx: Context = avr_port["pwm"]
        merge_counts = PWM_MERGE_US * pwm_ctx["num"] // pwm_ctx["den"]
    else:
        pwm = timing.pwm_timing(board.mcu.clock_hz)
        pwm_ctx = {"t1con": pwm.t1con, "prescale": pwm.prescale, "frame": pwm.frame_counts,
                   "num": pwm.num, "den": pwm.den}
        merge_counts = pwm.counts(PWM_MERGE_US)
    servos = robot.servos
    ctx.update({
        "servos": [{"name": s.name, "index": s.index, "min": s.min_angle, "max": s.max_angle,
                    "stand": s.stand_angle, "speed": s.default_speed,
                    "pulse_min": s.pulse_min_us, "pulse_max": s.pulse_max_us,
                    "pin": _pin(s.pin)} for s in servos],
        "n_servos": len(servos),
        "registers": 2 * len(servos),
        "address": _slave_address(board),
        "pwm": pwm_ctx,
        "pwm_ports": [{"port": port, "mask": sum(_pin(s.pin)["mask"] for s in servos
                                                 if _pin(s.pin)["port"] == port)}
                      for port in sorted({_pin(s.pin)["port"] for s in servos})],
        "pwm_merge_counts": merge_counts,
        "initial_regs": servo.initial_registers(servos),
    })
    if avr_port is not None:
        ctx["avr"] = avr_port
    return ctx


def _sensor_rows(board: Board) -> list[dict[str, Any]]:
    """One row per sensor: the ADC channel it is converted on (the mux's for a sensor on a
    mux input), that channel's pin, and its mux input (None: on its own channel)."""
    rows = []
    for s in board.sensors:
        channel = s.channel if s.channel is not None else board.mux.channel  # type: ignore[union-attr]
        rows.append({"name": s.name, "channel": channel, "group": s.group,
                     "pin": board.spec.adc_pins[channel], "input": s.mux_input})
    return rows


def _mux_context(board: Board) -> dict[str, Any] | None:
    """The analog multiplexer (None without one): its channel, inputs, select pins (S0
    first, each with its port and mask) and settling time."""
    m = board.mux
    if m is None:
        return None
    select = [dict(_pin(p), s=i) for i, p in enumerate(m.select)]
    return {"channel": m.channel, "inputs": m.inputs, "settle_us": m.settle_us,
            "select": select,
            "ports": [{"port": port, "mask": sum(p["mask"] for p in select if p["port"] == port)}
                      for port in sorted({p["port"] for p in select})]}


def sensor_context(robot: Robot) -> Context:
    board = robot.sensor_board
    assert board is not None
    ctx = common_context(robot, board)
    sensors = robot.sensors
    ctx["mux"] = _mux_context(board)
    if board.spec.family == "avr":
        ctx["avr"] = ports.sensor_avr(board)
        ctx.update({"sensors": _sensor_rows(board),
                    "n_sensors": len(sensors), "registers": 2 * len(sensors),
                    "address": _slave_address(board)})
        return ctx
    adc = timing.adc_clock(board.mcu.clock_hz)
    settle = board.mux.settle_us if board.mux is not None else 0
    ctx.update({
        "sensors": _sensor_rows(board),
        "n_sensors": len(sensors),
        "registers": 2 * len(sensors),
        "address": _slave_address(board),
        # Timer0: 16-bit, Fosc/4, prescale 1:8 (T0CON 0x82): counts of the acquisition time
        "t0con": 0x82,
        "acq_counts": -(-ADC_ACQ_US * board.mcu.clock_hz // (4 * 8 * 1_000_000)),
        # ... and of the mux's settling time plus the acquisition time (a select change)
        "mux_acq_counts": -(-(ADC_ACQ_US + settle) * board.mcu.clock_hz // (4 * 8 * 1_000_000)),
        "adc": {"divisor": adc.divisor, "adcs2": adc.adcs2, "adcs": adc.adcs,
                # ADCON1: right-justified (ADFM), ADCS2, PCFG=0000 (AN0..AN7 analog)
                "adcon1": 0x80 | (adc.adcs2 << 6),
                # ADCON0 without channel bits: ADCS1:0, ADON
                "adcon0": (adc.adcs << 6) | 0x01},
    })
    return ctx


def _slave_address(board: Board) -> dict[str, int]:
    if board.i2c.address is None:
        raise GenerateError(f"board '{board.board}' is an I2C slave without an address")
    return {"address": board.i2c.address, "sspadd": board.i2c.address << 1}


BUILDERS = {"central": central_context, "actuator": actuator_context,
            "sensor": sensor_context}


def board_context(robot: Robot, role: str) -> Context:
    return BUILDERS[role](robot)
