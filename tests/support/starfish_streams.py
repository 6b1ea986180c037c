"""Hypothesis strategies of STARFISH central-board stimulus steps, shared by the PIC
(gpsim) and ATmega328P (simavr) differential tests: command lines (velocity, wheel,
odometry, stop, version, bad ones), ticks (a long one past the watchdog), floors and
(with ``flow=True``) flow sensor motions."""

from __future__ import annotations

from hypothesis import strategies as st

FIELD = st.integers(-999, 999).map(lambda v: f"{v:+05d}")
LINE = st.one_of(
    st.tuples(st.sampled_from("VW"), FIELD, FIELD, FIELD).map("".join),
    st.sampled_from(["O", "x", "v", "Q", "O*00", "V+0100", "V+0600+0000+0000", ""]))
STEP = st.one_of(
    LINE.map(lambda text: f"rx {text}"),
    st.integers(1, 8).map(lambda n: f"tick {n}"),
    st.tuples(st.integers(0, 1), st.integers(0, 1)).map(lambda f: f"floor {f[0]} {f[1]}"),
    st.just("tick 55"))
MOTION = st.tuples(st.integers(0, 1), st.integers(-128, 127), st.integers(-128, 127),
                   st.integers(0, 255)).map(lambda m: "flow {} {} {} {}".format(*m))


def steps(flow: bool = False) -> st.SearchStrategy[list[str]]:
    return st.lists(st.one_of(STEP, MOTION) if flow else STEP, min_size=3, max_size=12)
