"""The short human summary ``esair std check`` prints for a valid deployment."""

from __future__ import annotations

from collections.abc import Mapping

from ..level import Level
from .model import BehaviorSpec, ComponentSpec, Deployment, ReactionSpec, ResourceSpec


def _plural(n: int, word: str) -> str:
    return f"{n} {word}" if n == 1 else f"{n} {word}s"


def _levels(mapping: Mapping[str, Level]) -> str:
    return ", ".join(f"{k}: {v.name}" for k, v in mapping.items())


def _options(options: Mapping[str, object]) -> str:
    return "  options " + ", ".join(f"{k}={v!r}" for k, v in options.items()) if options else ""


def _seconds(value: float) -> str:
    return f"{value:g} s"


def deployment_summary(dep: Deployment) -> list[str]:
    """One line for the robot, one per component, in deployment order."""
    lines = [f"robot '{dep.robot}': mode {dep.mode}, endpoint {dep.endpoint}, "
             f"{_plural(len(dep.resources), 'resource')}, "
             f"{_plural(len(dep.behaviors), 'behavior')}, "
             f"{_plural(len(dep.reactions), 'reaction')}"
             + (", security set" if dep.security is not None else "")]
    width = max((len(n) for s in (dep.resources, dep.behaviors, dep.reactions) for n in s),
                default=0)
    for kind, spec in dep.components():
        lines.append(f"  {kind:<8} {spec.name:<{width}}  {spec.class_path}  "
                     f"{_details(spec)}{_options(spec.options)}".rstrip())
    return lines


def _details(spec: ComponentSpec) -> str:
    if isinstance(spec, ResourceSpec):
        allow = f"allow {_levels(spec.allow)}" if spec.allow else "allow nobody"
        r = spec.restart
        return allow + (f"  restart {_plural(r.max, 'time')} in {_seconds(r.within)}"
                        if r.max else "")
    if isinstance(spec, BehaviorSpec):
        period = f"period {_seconds(spec.period)}" if spec.period else "period of the class"
        uses = f"  uses {_levels(spec.uses)}" if spec.uses else ""
        r = spec.restart
        restart = (f"restart {_plural(r.max, 'time')} in {_seconds(r.within)}" if r.max
                   else "no restart")
        return f"{period}{uses}  {restart}"
    if isinstance(spec, ReactionSpec):
        res = f"resources {', '.join(spec.resources)}" if spec.resources else "no resources"
        period = f"  period {_seconds(spec.period)}" if spec.period else ""
        return f"{res}{period}  {'enabled' if spec.enabled else 'disabled'}"
    return ""
