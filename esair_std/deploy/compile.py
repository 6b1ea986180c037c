"""A checked deployment made plain data (the lean robot side, esair_std/lean/).

Runs where pydantic may be loaded (``esair std run``'s short-lived checking child):
the deployment read and checked as ``esair std check`` does, every class imported and
its options checked, then each component whose class has ``prepare_entry`` (a driver:
``MinLink``; a behavior: STARFISH's ``TurnAndShoot``) prepared — its options checked
and its board model reduced to what it uses — and all of it written as JSON with the
list of files it was made from (the deployment, each class's module, the board files),
which the cache hashes.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

from esair_min.config.yamlload import Document

from ..lean.plain import PlainDeployment
from ..spec import Spec, specs_of
from ..transport.codec import JSONObject
from .class_check import load_classes
from .loader import load_document


def compile_deployment(path: str | Path, edit: Callable[[Document], None] | None = None,
                       ) -> tuple[JSONObject, list[str]] | None:
    """(the plain deployment's JSON, the files it was made from); None when it is not
    made plain (a security section: the runtime reads its pydantic model). Every
    problem of the deployment raises as :func:`load_document` and ``load_classes``
    raise it (DeployError at file:line)."""
    dep, _doc = load_document(path, edit=edit)
    if dep.security is not None:
        return None
    classes = load_classes(dep)
    inputs: list[str] = [dep.source] if dep.source else []
    res, beh, rea = specs_of(dep)
    specs: list[Spec] = []
    for spec in res + rea + beh:
        cls = classes[spec.name]
        module_file = getattr(sys.modules.get(cls.__module__), "__file__", None)
        if module_file:
            inputs.append(str(module_file))
        prepare = getattr(cls, "prepare_entry", None)
        if callable(prepare):
            try:
                prepared = prepare(dict(spec.options), spec.base_dir, spec.name)
            except Exception:  # noqa: BLE001 - its open()/start() fails the same way
                prepared = None
            if isinstance(prepared, dict):
                inputs += [str(f) for f in prepared.get("inputs", ())]
            # a resource's: a serial link (a MinLink or a class derived from it): a page's
            # link bar shows it, though the runtime never imports its class
            # (observe.v_describe)
            link: JSONObject = {"link": True} if spec.kind == "resource" else {}
            if spec.kind == "resource" or isinstance(prepared, dict):
                spec = Spec.from_json({**spec.to_json(), "prepared": {
                    **(prepared if isinstance(prepared, dict) else {}), **link}})
        specs.append(spec)
    plain = PlainDeployment(dep.robot, dep.mode, dep.endpoint, str(dep.base_dir),
                            dep.source, specs)
    return plain.to_json(), list(dict.fromkeys(inputs))
