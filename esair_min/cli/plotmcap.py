"""``esair plot FILE.mcap``: a recording of an STD robot (``esair std record``, the HMI's
record button) drawn over time: one panel per channel with its numbers (a value, or the
numbers of an object one level deep: the feet's sensors and group sums), the notices'
reactions (``R ...``) as red lines on every panel."""

from __future__ import annotations

import json
from pathlib import Path

from esair_min.errors import EsairError


def _numbers(value: object) -> dict[str, float]:
    if isinstance(value, bool):
        return {}
    if isinstance(value, (int, float)):
        return {"value": float(value)}
    out: dict[str, float] = {}
    if isinstance(value, dict):
        for k, v in value.items():
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                out[k] = float(v)
            elif isinstance(v, dict):
                out.update({f"{k}.{k2}": float(v2) for k2, v2 in v.items()
                            if isinstance(v2, (int, float)) and not isinstance(v2, bool)})
    return out


def read_mcap(path: Path | str) -> tuple[dict[str, dict[str, list]], list[tuple[float, str]], int]:
    """Per channel {field: [(t, number)...]}, the reactions (t, notice), and how many
    samples had numbers to draw."""
    from mcap.reader import make_reader
    series: dict[str, dict[str, list]] = {}
    reactions: list[tuple[float, str]] = []
    samples = 0
    try:
        with open(path, "rb") as f:
            for schema, channel, message in make_reader(f).iter_messages(log_time_order=True):
                name = schema.name if schema is not None else "esair.Sample"
                if name != "esair.Sample" and not name.startswith("esair.Sample."):
                    continue                    # commands, the latch, Foxglove's: not samples
                m = json.loads(message.data)
                t, value = float(m["t"]), m["value"]
                if isinstance(value, dict) and isinstance(value.get("notice"), str):
                    if value["notice"].startswith("R "):
                        reactions.append((t, value["notice"]))
                    continue
                numbers = _numbers(value)
                samples += bool(numbers)
                for k, v in numbers.items():
                    series.setdefault(channel.topic, {}).setdefault(k, []).append((t, v))
    except OSError as exc:
        raise EsairError(f"cannot read {path}: {exc.strerror}") from None
    except Exception as exc:  # noqa: BLE001 - the mcap reader's and JSON's errors
        raise EsairError(f"{path} is not an MCAP recording of ESAIR samples: {exc}") from None
    return series, reactions, samples


def plot_mcap(path: Path | str, out: Path | str) -> tuple[int, int]:
    """Draw the recording into the PNG ``out``; returns the samples drawn and the numbers
    in them (the feet's: 8 readings and 2 sums a sample)."""
    series, reactions, samples = read_mcap(path)
    if not series:
        raise EsairError(f"{path} holds no numeric samples to plot")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t0 = min(p[0][0] for fields in series.values() for p in fields.values())
    fig, axes = plt.subplots(len(series), 1, figsize=(10, 2.6 * len(series)), squeeze=False,
                             sharex=True)
    n = 0
    for ax, (topic, fields) in zip(axes[:, 0], sorted(series.items()), strict=True):
        for name, pts in fields.items():
            ax.plot([p[0] - t0 for p in pts], [p[1] for p in pts], label=name, linewidth=1)
            n += len(pts)
        for t, _text in reactions:
            ax.axvline(t - t0, color="red", linewidth=1)
        ax.set_title(topic, fontsize=9, loc="left")
        ax.legend(fontsize=7, ncol=4, loc="upper right")
    axes[-1, 0].set_xlabel(f"seconds from the first sample ({Path(path).name}); red: reactions")
    fig.tight_layout()
    try:
        fig.savefig(out, dpi=100)
    except OSError as exc:
        raise EsairError(f"cannot write {out}: {exc.strerror}") from None
    finally:
        plt.close(fig)
    return samples, n
