"""The runtime as the parts it is made of see it (runtime.py builds it; the modes, the
operator, the listing, the remote center and remote robots are handed it): a
``typing.Protocol`` naming what they read of it, so that nothing types it ``Any`` and
nothing imports the runtime's class (runtime.py imports them)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Mapping, Protocol

if TYPE_CHECKING:  # pragma: no cover
    from .bs import BehaviorSupervisor
    from .connections import ActuatorConnection, SensorConnection
    from .deploy.model import Deployment
    from .lean.plain import PlainDeployment
    from .level import Level
    from .parts import Mode, RemoteComponent
    from .rs import ResourceSupervisor
    from .transport.bus import Bus
    from .transport.calls import SampleServer
    from .transport.codec import JSONObject


class ControlLink(Protocol):
    """The control endpoint's session, as others publish and serve through it."""

    @property
    def bus(self) -> Bus | None: ...
    @property
    def puts(self) -> SampleServer: ...


class RemoteAgents(Protocol):
    """The remote agents' center (remote/center.py), as process mode tells it."""

    def lost(self, host: RemoteComponent) -> None: ...


class RuntimeView(Protocol):
    """One robot's runtime: its names, its resident components and its modes' links."""

    @property
    def robot(self) -> str: ...
    @property
    def mode_name(self) -> str: ...
    @property
    def endpoint(self) -> str: ...
    @property
    def local_endpoint(self) -> str | None: ...
    @property
    def base_dir(self) -> str: ...
    @property
    def hostname(self) -> str: ...
    @property
    def deployment(self) -> Deployment | PlainDeployment: ...
    child_session: dict[str, str] | None   # the runtime's own login, for its children

    @property
    def bs(self) -> BehaviorSupervisor: ...
    @property
    def rs(self) -> ResourceSupervisor: ...
    @property
    def sc(self) -> SensorConnection: ...
    @property
    def ac(self) -> ActuatorConnection: ...
    @property
    def mode(self) -> Mode: ...
    @property
    def server(self) -> ControlLink | None: ...
    @property
    def center(self) -> RemoteAgents | None: ...

    def state(self, name: str) -> str | None: ...
    def ls(self) -> list[JSONObject]: ...
    def note_change(self) -> None: ...
    # the latched STOP (latch.py)
    def stop_robot(self, reason: str = "", by: str = "operator") -> JSONObject: ...
    def release_robot(self, by: str = "operator") -> JSONObject: ...
    @property
    def latched(self) -> JSONObject | None: ...


class Robot(RuntimeView, Protocol):
    """The robot's own operations, as the control endpoint answers them (runtime.py)."""

    extra_listen: list[str]
    join: list[str]
    started_at: float        # 0 while it starts (its deployment's components being added)
    session_options: Mapping[str, object] | None

    def add(self, name: str, class_path: str, uses: Mapping[str, Level | str] | None = None,
            period: float | None = None, options: JSONObject | None = None) -> str: ...
    def remove(self, name: str) -> None: ...
    def add_resource(self, name: str, class_path: str,
                     allow: Mapping[str, Level | str] | None = None,
                     options: JSONObject | None = None) -> dict[str, str]: ...
    def remove_resource(self, name: str) -> list[str]: ...
    def inspect(self, name: str) -> JSONObject: ...
