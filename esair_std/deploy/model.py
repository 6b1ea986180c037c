"""The deployment model: one frozen description of what a robot's host runs.

These classes are the single definition of the deployment file format: the loader
builds them from YAML (or a dict), ``esair std schema`` prints their JSON Schema and
the runtime reads them. Rules that involve more than one entry (``uses`` against
``allow``, names across sections) live in :mod:`esair_std.deploy.rules`; class imports
in :mod:`esair_std.classes` (the runtime's importer too). Build a Deployment with
:func:`esair_std.deploy.load_deployment`, which also fills the fields marked
*set by the loader* below (they are not keys of the file).
"""

from __future__ import annotations

from fnmatch import fnmatchcase
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal

from pydantic import (BaseModel, ConfigDict, Field, InstanceOf, PlainSerializer, PlainValidator,
                      StrictBool, StrictFloat, StrictInt, StrictStr, WithJsonSchema,
                      model_validator)
from pydantic.json_schema import SkipJsonSchema
from pydantic_core import PydanticCustomError

from esair_min.config.yamlload import Document
from esair_min.errors import Mark

from ..classes import CLASS_PATTERN as CLASS_PATTERN  # ``module:Class``: the importer's own
from ..endpoint import DEFAULT_ENDPOINT as DEFAULT_ENDPOINT, PROTOCOLS as PROTOCOLS
from ..level import Level
from .security import SecuritySpec

#: A component or robot name: also a Zenoh key chunk, so no '.', '*', '/', '$', '?'.
NAME_PATTERN = r"^[a-z][a-z0-9_]{0,31}$"
#: A resource in ``uses``/``allow``/reaction ``resources``: a name, ``entry.child``
#: (a driver's child) and, in ``uses`` and ``allow``, fnmatch wildcards.
REF_PATTERN = r"^[a-z0-9_.*?\[\]!-]{1,96}$"
CHILD_PATTERN = r"^[a-z][a-z0-9_]{0,31}(\.[a-z][a-z0-9_]{0,31})*$"
#: Endpoints the runtime can listen on (Zenoh locators).
ENDPOINT_PATTERN = (r"^((tcp|udp|tls|quic|ws)/(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):[0-9]{1,5}"
                    r"|unixsock-stream/.+)$")

Name = Annotated[StrictStr, Field(pattern=NAME_PATTERN)]
Ref = Annotated[StrictStr, Field(pattern=REF_PATTERN)]
Seconds = Annotated[StrictFloat, Field(gt=0, allow_inf_nan=False)]

LEVEL_CHOICES = "'read', 'command' or 'configure'"


def _level(value: object) -> Level:
    if isinstance(value, Level):
        return value
    if isinstance(value, str) and value in Level.__members__:
        return Level[value]
    # Same error type as a Literal: the YAML error machinery words it with did-you-mean.
    raise PydanticCustomError("literal_error", "Input should be {expected}",
                              {"expected": LEVEL_CHOICES})


LevelName = Annotated[
    Level, PlainValidator(_level), PlainSerializer(lambda lv: lv.name, return_type=str),
    WithJsonSchema({"type": "string", "enum": [lv.name for lv in Level],
                    "description": "usage level: read < command < configure"})]


class _Frozen(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, defer_build=True)


class RestartPolicy(_Frozen):
    """At most ``max`` restarts within ``within`` seconds; then the behavior (or the
    resource entry) stays failed."""

    max: Annotated[StrictInt, Field(ge=0, le=1000)] = Field(
        0, description="restarts allowed within the window (0: never restart)")
    within: Seconds = Field(10.0, description="the window, in seconds")


#: Keys of a component entry that are not options, per section.
COMMON_KEYS = ("class", "options")


class ComponentSpec(BaseModel):
    """What resources, behaviors and reactions share: the class and its options.

    Every key of the entry that is not one of the section's keys is an option (so is
    everything under ``options:``); options go to the component as ``self.options``.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True, defer_build=True,
                              json_schema_extra={"additionalProperties": True})
    KEYS: ClassVar[tuple[str, ...]] = COMMON_KEYS

    class_path: StrictStr = Field(alias="class", pattern=CLASS_PATTERN,
                                  description="module:Class; the module is imported from "
                                              "the deployment file's folder first, then "
                                              "sys.path")
    options: dict[str, Any] = Field(default_factory=dict,
                                    description="options for the component (self.options); "
                                                "other keys of the entry are added to them")
    # Set by the loader, not keys of the file:
    name: SkipJsonSchema[str] = Field("", exclude=True, description="the entry's name")
    mark: SkipJsonSchema[InstanceOf[Mark] | None] = Field(
        None, exclude=True, repr=False, description="where the entry's name is written")
    class_mark: SkipJsonSchema[InstanceOf[Mark] | None] = Field(
        None, exclude=True, repr=False, description="where its class is written")
    base_dir: SkipJsonSchema[Path] = Field(Path("."), exclude=True, repr=False,
                                           description="folder its module is imported from "
                                                       "first")
    options_doc: SkipJsonSchema[InstanceOf[Document] | None] = Field(
        None, exclude=True, repr=False, description="where each option is written")

    @model_validator(mode="before")
    @classmethod
    def _gather_options(cls, data: object) -> object:
        """Keys that are not the section's own go to ``options``."""
        if not isinstance(data, dict):
            return data
        own = set(cls.KEYS) | {"name", "mark", "class_mark", "base_dir", "class_path",
                               "options_doc"}
        extra = {k: v for k, v in data.items() if k not in own}
        if not extra:
            return data
        out = {k: v for k, v in data.items() if k in own}
        given = out.get("options", {})
        out["options"] = {**extra, **given} if isinstance(given, dict) else given
        return out



class ResourceSpec(ComponentSpec):
    """A resource: a Sensor, an Actuator, or a Driver providing several (``entry.child``)."""

    KEYS = COMMON_KEYS + ("allow", "restart")

    allow: dict[Ref, LevelName] = Field(
        default_factory=dict,
        description="behavior name or fnmatch pattern -> highest level it may register "
                    "for (read < command < configure); nobody when empty")
    restart: RestartPolicy = Field(default_factory=RestartPolicy,
                                   description="restart policy after its host fails")

    def granted(self, behavior: str) -> Level | None:
        """The highest level ``allow`` grants ``behavior`` (None: not allowed at all)."""
        levels = [lv for pattern, lv in self.allow.items() if fnmatchcase(behavior, pattern)]
        return max(levels) if levels else None


class BehaviorSpec(ComponentSpec):
    """A behavior: the user's deliberative code, supervised by the BS."""

    KEYS = COMMON_KEYS + ("period", "uses", "restart")

    period: Seconds | None = Field(
        None, description="seconds between step() calls; not given: the class's period "
                          "(None there: run() once)")
    uses: dict[Ref, LevelName] = Field(
        default_factory=dict,
        description="resources (names, entry.child, fnmatch patterns) and the level the "
                    "behavior registers for; each must be granted by the resource's allow")
    restart: RestartPolicy = Field(default_factory=RestartPolicy,
                                   description="restart policy after a failure")


class ReactionSpec(ComponentSpec):
    """A reaction: resident, immediate, reaching its fixed resources directly."""

    KEYS = COMMON_KEYS + ("resources", "enabled", "period")

    resources: tuple[Annotated[StrictStr, Field(pattern=CHILD_PATTERN)], ...] = Field(
        (), description="the resources it reaches directly (names or entry.child)")
    enabled: StrictBool = Field(True, description="enabled at start")
    period: Seconds | None = Field(
        None, description="seconds between step() calls; not given: the class's period")


Section = Literal["resources", "behaviors", "reactions"]
SECTIONS: tuple[Section, ...] = ("resources", "behaviors", "reactions")
#: The kind of component each section holds (singular, for messages).
KIND = {"resources": "resource", "behaviors": "behavior", "reactions": "reaction"}


class Deployment(_Frozen):
    """A robot's deployment: resources, behaviors and reactions, each in file order."""

    robot: Name = Field(description="the robot's name; Zenoh keys are esair/<robot>/...")
    mode: Literal["thread", "process"] = Field(
        "thread", description="thread: every component a thread of one process; process: "
                              "each its own OS process, joined by Zenoh")
    endpoint: StrictStr = Field(DEFAULT_ENDPOINT, pattern=ENDPOINT_PATTERN,
                                description="control endpoint the runtime listens on "
                                            "(PROTOCOL/HOST:PORT)")
    resources: dict[Name, ResourceSpec] = Field(default_factory=dict,
                                                description="deployed first, in this order")
    behaviors: dict[Name, BehaviorSpec] = Field(default_factory=dict,
                                                description="started in this order")
    reactions: dict[Name, ReactionSpec] = Field(default_factory=dict,
                                                description="started in this order")
    security: SecuritySpec | None = Field(None, description="transport security "
                                                            "(docs/std-deployment.md)")
    # Set by the loader, not keys of the file:
    source: SkipJsonSchema[str | None] = Field(None, exclude=True,
                                               description="the file it was read from")
    base_dir: SkipJsonSchema[Path] = Field(Path("."), exclude=True,
                                           description="the file's folder (or the cwd)")

    def component(self, name: str) -> ComponentSpec | None:
        """The resource, behavior or reaction called ``name`` (None if none)."""
        for section in SECTIONS:
            spec: ComponentSpec | None = getattr(self, section).get(name)
            if spec is not None:
                return spec
        return None

    def components(self) -> list[tuple[str, ComponentSpec]]:
        """(kind, spec) of every component, resources first, each section in file order."""
        return [(KIND[s], spec) for s in SECTIONS for spec in getattr(self, s).values()]


def top_keys() -> list[str]:
    """The keys a deployment file may have at its top level."""
    return [n for n, f in Deployment.model_fields.items() if not f.exclude]
