"""Command streams that overrun the central board's 64-byte receive ring (not a test
module: the overrun tests and the differential tests share these strategies).

The ring only fills while a held actuator write (``t``, ``oMSAAA``, ``c...``) keeps the
decoder from reading until the next tick, so the streams are bursts of many lines, rich
in such commands, with ticks between them.
"""

from __future__ import annotations

from hypothesis import strategies as st

SERVOS = "abcdefghijkl"


def esc(data: bytes) -> str:
    """Bytes as an rx text: letters and digits as they are, everything else \\xHH."""
    return "".join(chr(b) if chr(b).isalnum() and b < 0x80 else f"\\x{b:02X}" for b in data)


motor = st.builds(lambda m, s, a: f"o{m}{s}{a:03d}", st.sampled_from(SERVOS),
                  st.sampled_from("abc"), st.integers(40, 140))
angles = st.builds(lambda cs: "c" + "".join(cs), st.lists(st.sampled_from("ABCD.0Ul"),
                                                          min_size=12, max_size=12))
line_text = st.one_of(
    st.sampled_from(["t", "t", "t", "x", "v", "s", "SIT", "DNC", "PLY01", "PLY04", "", "zz",
                     "a" + "001" * 12]),
    motor, motor, angles,
    st.text(st.sampled_from("tovcxSITDNPLY0123456789abc"), max_size=14),
)
line_end = st.sampled_from([b"\r", b"\r", b"\n", b"\r\n"])
command = st.builds(lambda text, end: text.encode("ascii") + end, line_text, line_end)
#: many lines at once: more than the ring holds while a write is held
burst = st.lists(command, min_size=1, max_size=40).map(b"".join)
garbage = st.binary(min_size=1, max_size=8).filter(lambda b: b"\r" not in b and b"\n" not in b)

step = st.one_of(
    burst.map(lambda b: f"rx {esc(b)}"),
    burst.map(lambda b: f"rx {esc(b)}"),
    st.tuples(burst, garbage, burst).map(lambda t: f"rx {esc(b''.join(t))}"),
    st.integers(1, 3).map(lambda n: f"tick {n}"),
    st.just("tick 12"),
    st.just("boot"),
)
#: stimulus scripts (lists of lines), booted first
scripts = st.lists(step, min_size=1, max_size=14).map(lambda steps: ["boot", *steps])
