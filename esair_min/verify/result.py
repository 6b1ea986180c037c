"""What ``esair verify`` found: the runs, the comparisons, the budgets (printed by
:mod:`esair_min.verify.report`, or as JSON)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

from esair_min.verify.budgets import Budget
from esair_min.verify.compare import Comparison
from esair_min.verify.default_scenario import Scenario
from esair_min.verify.targets import TargetRun


@dataclass
class Report:
    robot: str
    targets: tuple[str, ...]
    scenario: Scenario
    script_name: str
    runs: dict[str, TargetRun] = field(default_factory=dict)
    comparisons: dict[str, Comparison] = field(default_factory=dict)
    budgets: list[Budget] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def ok(self) -> bool:
        return (all(c.equal for c in self.comparisons.values())
                and all(b.ok for b in self.budgets))

    def as_dict(self) -> dict[str, Any]:
        return {
            "robot": self.robot, "ok": self.ok, "seconds": round(self.seconds, 2),
            "scenario": {"script": self.script_name, "covers": self.scenario.covers,
                         "skipped": self.scenario.skipped},
            "targets": [{"target": t, "seconds": round(self.runs[t].seconds, 2),
                         "events": len(self.runs[t].trace),
                         "equal": self.comparisons[t].equal if t in self.comparisons else None,
                         "differences": [vars(d) for d in self.comparisons[t].differences]
                         if t in self.comparisons else []}
                        for t in self.targets if t in self.runs],
            "budgets": [b.as_dict() for b in self.budgets],
        }


Progress = Callable[[str], None]
