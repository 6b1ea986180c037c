"""``esair eeprom``: build the motion image (a file), or put it into a robot over its
serial link, read it back, verify it (esair_min.imagelink)."""

from __future__ import annotations

import sys
from typing import Any, Callable

import click

from esair_min.errors import EsairError, ImageError


def _progress(label: str, total: int) -> tuple[Callable[[int, int], None], Callable[[], None]]:
    """A bar on a terminal, a line per tenth otherwise: (update, finish)."""
    if sys.stderr.isatty():
        bar: Any = click.progressbar(length=total, label=label, file=sys.stderr)
        bar.__enter__()
        seen = [0]

        def update(done: int, _total: int) -> None:
            bar.update(done - seen[0])
            seen[0] = done

        return update, lambda: bar.__exit__(None, None, None)
    step = [0]

    def plain(done: int, total_: int) -> None:
        tenth = done * 10 // max(total_, 1)
        if tenth > step[0]:
            step[0] = tenth
            click.echo(f"{label} {done}/{total_} bytes", err=True)

    return plain, lambda: None


def build_file(model: Any, output: str, raw: bool) -> str:
    from esair_min.core.image import build_image, image_summary, write_hex

    data = build_image(model)
    if raw:
        try:
            with open(output, "wb") as f:
                f.write(data)
        except OSError as exc:
            raise ImageError(f"cannot write {output}: {exc.strerror}") from None
    else:
        write_hex(data, output)
    return f"{image_summary(model, data)} -> {output}"


def over_link(model: Any, port: str, baud: int | None, write: bool, verify: bool,
              read: str | None, timeout: float) -> int:
    """--write/--verify/--read on ``port``; the exit status (1: verify found differences)."""
    import serial

    from esair_min.core.image import build_image, write_hex
    from esair_min.imagelink import ImageLink
    from esair_min.serialport import describe, open_port

    rate = baud or (model.central.uart.baud if model.central.uart else 9600)
    try:
        ser = open_port(port, baudrate=rate, timeout=0.05)
    except (serial.SerialException, ValueError, OSError) as exc:
        raise EsairError(f"cannot open {port}: {describe(exc)}") from None
    with ser:
        link = ImageLink(ser, model, timeout)
        image = build_image(model)
        if write:
            update, finish = _progress("writing", len(image))
            try:
                res = link.write_image(image, update)
            finally:
                finish()
            if res.written == 0:
                click.echo(f"{model.name}: the robot already holds this image "
                           f"(CRC 0x{res.crc:04X}); nothing written")
            else:
                click.echo(f"{model.name}: wrote {res.written} of {res.chunks} chunks "
                           f"({len(image)} bytes) in {res.seconds:.2f} s; image valid, "
                           f"CRC 0x{res.crc:04X}")
            return 0
        if verify:
            update, finish = _progress("verifying", len(image))
            try:
                bad = link.verify(image, update)
                crc = link.robot_crc()
            finally:
                finish()
            want = int.from_bytes(image[6:8], "little")
            if not bad and crc == want:
                click.echo(f"{model.name}: the robot holds this image (CRC 0x{want:04X})")
                return 0
            where = ", ".join(f"0x{a:04X}" for a in bad[:8]) + (" ..." if len(bad) > 8 else "")
            state = "valid" if crc is not None else "not valid"
            click.echo(f"{model.name}: the robot's image differs ({len(bad)} chunks"
                       f"{': ' + where if bad else ''}; its image is {state}"
                       f"{f', CRC 0x{crc:04X}' if crc is not None else ''}); run esair "
                       f"eeprom {model.name} --write {port}")
            return 1
        assert read is not None
        update, finish = _progress("reading", 0)
        try:
            data = link.read_image(update)
        finally:
            finish()
        write_hex(data, read)
        click.echo(f"{model.name}: read {len(data)} bytes -> {read}")
        return 0
