"""``esair std run ROBOT --port PORT``: the same deployment pointed at another serial port."""

from __future__ import annotations

from typing import Any

from .errors import LinkError

CLASS = "esair_std.drivers.minlink:MinLink"


def with_port(deployment: Any, port: str) -> Any:
    """A copy of ``deployment`` (a loaded, frozen Deployment) whose MinLink resources
    open ``port`` instead of their own (``emulate:`` dropped)."""
    changed = {}
    for name, spec in deployment.resources.items():
        if spec.class_path == CLASS:
            options = {k: v for k, v in spec.options.items() if k != "emulate"}
            options["port"] = port
            changed[name] = spec.model_copy(update={"options": options})
    if not changed:
        raise LinkError(f"--port {port}: the deployment has no MinLink resource "
                        f"(class {CLASS})")
    return deployment.model_copy(update={"resources": {**deployment.resources, **changed}})
