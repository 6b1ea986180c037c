"""A component class's own options schema: ``Options``, a pydantic model on the class
(a driver's ``MinLinkOptions``), checked against the entry's options when the deployment's
classes are imported, each error at the line of the option in the file.

The options of an entry are its keys that are not the section's own and those under
``options:`` (:class:`~esair_std.deploy.model.ComponentSpec`); :func:`options_document`
keeps, for each, where it was written.
"""

from __future__ import annotations

from pydantic import BaseModel, ValidationError

from esair_min.config.schema_errors import config_error
from esair_min.config.yamlload import Document
from esair_min.errors import Mark

from ..errors import DeployError
from .marks import Loc, dict_document


def options_document(doc: Document, entry: tuple[str, str], options: dict[str, object]) -> Document:
    """``options`` as a Document whose marks are where ``doc`` has them: an option written
    as a key of the entry (``entry + (key, ...)``) or under its ``options:``."""
    values: dict[Loc, Mark] = {}
    keys: dict[Loc, Mark] = {}
    for src, marks in ((doc.value_marks, values), (doc.key_marks, keys)):
        for loc, mark in src.items():
            if loc[:2] != entry or len(loc) < 3:
                continue
            rest = loc[2:]
            if rest[0] == "options":
                rest = rest[1:]
                if not rest:
                    continue
            marks[rest] = mark
    values.setdefault((), doc.mark(entry, key=True))
    return Document(doc.path, options, values, keys)


def options_model(cls: type) -> type[BaseModel] | None:
    """The class's ``Options`` schema, if it declares one: a pydantic model, or its
    ``module:Name`` (a driver whose module must not import pydantic: the robot side
    of ``esair std run`` imports the class, never its schema)."""
    model = getattr(cls, "Options", None)
    if isinstance(model, str) and ":" in model:
        import importlib
        module, _, attr = model.partition(":")
        model = getattr(importlib.import_module(module), attr, None)
    return model if isinstance(model, type) and issubclass(model, BaseModel) else None


def check_options(model: type[BaseModel], options: dict[str, object],
                  doc: Document | None = None) -> BaseModel:
    """``options`` as ``model``; a :class:`DeployError` at the option's place in ``doc``
    (by default: its path in ``options``) when they do not fit."""
    try:
        return model.model_validate(options)
    except ValidationError as exc:
        err = config_error(exc, doc if doc is not None else dict_document(options), model)
        raise DeployError(err.message, err.mark) from None
