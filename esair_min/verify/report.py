"""``esair verify``'s printed report: the targets' table, the first differences side by
side, the budgets' table with verdicts."""

from __future__ import annotations

from collections.abc import Sequence

from esair_min.verify.result import Report


def _table(rows: Sequence[tuple[str, ...]]) -> list[str]:
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip() for r in rows]


def _decode(line: str) -> str:
    """A ``TX`` line with its text shown too."""
    if line.startswith("TX "):
        try:
            return f"{line}  ({bytes.fromhex(line[3:]).decode('ascii').rstrip()})"
        except ValueError:
            return line
    return line


def report_lines(r: Report) -> list[str]:
    out = [f"robot {r.robot}: {r.script_name}"]
    if r.scenario.covers:
        out.append("  covers: " + "; ".join(r.scenario.covers))
    for s in r.scenario.skipped:
        out.append(f"  not covered: {s}")
    rows: list[tuple[str, ...]] = [("target", "events", "seconds", "vs python")]
    for t in r.targets:
        if t not in r.runs:
            continue
        run = r.runs[t]
        cmp = r.comparisons.get(t)
        verdict = ("reference" if cmp is None else "equal" if cmp.equal
                   else f"DIFFERS ({', '.join(d.part for d in cmp.differences)})")
        rows.append((t, str(len(run.trace)), f"{run.seconds:.1f}", verdict))
    out += [""] + _table(rows)
    for t, cmp in r.comparisons.items():
        for d in cmp.differences:
            if not d.python and not d.target:          # a simulator's own message
                out += ["", f"{t}: first difference in {d.part}: {d.note}"]
                continue
            out += ["", f"{t}: first difference in {d.part} (event {d.index})"
                    + (f", {d.note}" if d.note else "")]
            if d.line:
                out.append(f"  after script line {d.line}: {d.command}")
            out.append(f"  python: {_decode(d.python)}")
            out.append(f"  {t + ':':7} {_decode(d.target)}")
    if r.budgets:
        rows = [("target", "budget", "used", "allowed", "share", "verdict")]
        for b in r.budgets:
            rows.append((b.target, b.name, str(b.used), f"{b.allowed} {b.unit}",
                         f"{b.share:.1%}" if b.allowed else "-", "ok" if b.ok else "OVER"))
        out += [""] + _table(rows)
        for b in r.budgets:
            if not b.ok:
                out.append(f"{b.target}: {b.name} over budget: {b.used} > {b.allowed} "
                           f"{b.unit} ({b.detail}): {b.change}")
    out += ["", f"{'ok' if r.ok else 'FAILED'}: {len(r.runs)} targets in {r.seconds:.1f} s"]
    return out
