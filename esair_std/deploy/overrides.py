"""Changes the command line makes to a deployment before it is checked:
``esair std run FILE --port DEVICE`` and ``--trace``/``--scenario`` (the emulated
robot's options). They edit the document the loader read (marks kept), so the file goes
through the same checks as ``esair std check`` and errors keep their ``file:line:col``.
"""

from __future__ import annotations

from collections.abc import Mapping

from esair_min.config.yamlload import Document
from esair_min.errors import path_mark

from ..errors import DeployError


def _entries(doc: Document) -> dict[str, object]:
    data = doc.data
    resources = data.get("resources") if isinstance(data, dict) else None
    return resources if isinstance(resources, dict) else {}


def set_port(doc: Document, port: str) -> None:
    """``port`` on every resource entry that has a ``port`` option (its ``emulate``
    options dropped unless the new port is ``emulate``); none: DeployError."""
    hit = False
    for entry in _entries(doc).values():
        if isinstance(entry, dict) and "port" in entry:
            entry["port"] = port
            if port != "emulate":
                entry.pop("emulate", None)
            hit = True
    if not hit:
        raise DeployError(f"--port {port}: no resource of this deployment has a 'port' "
                          "option", path_mark(doc.path))


def set_emulate(doc: Document, options: Mapping[str, object]) -> None:
    """Merge ``options`` (e.g. ``{"trace": FILE}``) into the ``emulate`` options of every
    resource entry whose port is ``emulate``; none: DeployError naming the first option."""
    hit = False
    for entry in _entries(doc).values():
        if isinstance(entry, dict) and entry.get("port") == "emulate":
            old = entry.get("emulate")
            entry["emulate"] = {**(old if isinstance(old, dict) else {}), **options}
            hit = True
    if not hit:
        flag = "--" + next(iter(options)).replace("_", "-")
        raise DeployError(f"{flag}: no resource of this deployment runs an emulated robot "
                          "(port: emulate)", path_mark(doc.path))
