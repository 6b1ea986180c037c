"""Load a deployment (a YAML file or a dict) into a frozen :class:`Deployment`.

Three steps, each raising one :class:`DeployError` that points at the value to
change (``file:line:col`` in a file, the value's path in a dict):
the raw checks (:mod:`.raw`), the model (pydantic, worded by esair_min's schema
errors) and the rules across entries (:mod:`.rules`). Classes are not imported here
(see :func:`esair_std.deploy.load_class`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from pydantic import ValidationError

from esair_min.errors import ConfigError
from esair_min.config.schema_errors import config_error
from esair_min.config.yamlload import Document, FileKind, load_yaml

from ..errors import DeployError
from .class_options import options_document
from .marks import dict_document
from .model import SECTIONS, Deployment
from .raw import check_raw
from .rules import check_rules

#: How esair_min's YAML loader names a deployment file in its messages.
DEPLOYMENT_FILE = FileKind("deployment file", "a deployment", "robot:, resources:, behaviors:, ...")


def load_deployment(source: str | Path | Mapping[str, object], *,
                    base_dir: str | Path | None = None) -> Deployment:
    """Read and check a deployment.

    ``source`` is the path of a YAML file, or a mapping with the same keys. The
    classes' modules are imported (later, by the runtime or ``load_class``) from
    ``base_dir`` first: by default the file's folder, or the current folder for a
    mapping.
    """
    deployment, _ = load_document(source, base_dir=base_dir)
    return deployment


def read_document(source: str | Path | Mapping[str, object]) -> Document:
    """The YAML file (marks: line:column) or the mapping (marks: paths) as a Document."""
    if isinstance(source, Mapping):
        return dict_document(source)
    if not isinstance(source, (str, Path)):
        raise DeployError(f"a deployment is a file path or a mapping, not "
                          f"{type(source).__name__}")
    try:
        return load_yaml(source, DEPLOYMENT_FILE)
    except DeployError:
        raise
    except ConfigError as exc:
        raise DeployError(exc.message, exc.mark) from None


def load_document(source: str | Path | Mapping[str, object], *,
                  base_dir: str | Path | None = None,
                  edit: Callable[[Document], None] | None = None,
                  ) -> tuple[Deployment, Document]:
    """:func:`load_deployment`, also returning the Document (for marks in messages).
    ``edit`` changes the document read before it is checked (the command line's
    ``--port``, :mod:`.overrides`)."""
    doc = read_document(source)
    if edit is not None:
        edit(doc)
    if base_dir is not None:
        base = Path(base_dir).resolve()
    elif isinstance(source, Mapping):
        base = Path.cwd()
    else:
        base = Path(source).resolve().parent
    data = check_raw(doc)
    _add_loader_fields(data, doc, base)
    try:
        deployment = Deployment.model_validate(data)
    except ValidationError as exc:
        err = config_error(exc, doc, Deployment)
        raise DeployError(err.message, err.mark) from None
    check_rules(deployment, doc)
    return deployment, doc


def _add_loader_fields(data: dict[str, object], doc: Document, base: Path) -> None:
    """Fill what is not written in the file: source, folder, each entry's name and marks."""
    data["source"] = None if doc.path == "<dict>" else doc.path
    data["base_dir"] = base
    for section in SECTIONS:
        entries = data.get(section)
        if not isinstance(entries, dict):
            continue
        for name, entry in entries.items():
            if isinstance(entry, dict):
                loc = (section, name)
                options = entry.get("options")
                entry.update(name=name, mark=doc.mark(loc, key=True),
                             class_mark=doc.mark(loc + ("class",)), base_dir=base,
                             options_doc=options_document(
                                 doc, loc, options if isinstance(options, dict) else {}))
