"""Control-socket methods a robot profile brings (``delivery.confirm_loaded`` ...).

A profile offers them from ``control_methods(ctx)``; they are served beside the core methods
with no branch on the profile's name here. Names must be ``<profile>.<method>`` and may not
shadow a core method. A ValueError from a method is an invalid-params error, ``ControlRefused``
an application error; both keep their message, and the connection stays usable.
"""

from __future__ import annotations

from collections.abc import Collection
from typing import Any

from behaviours.context import RobotContext
from behaviours.profile import ControlMethod, ControlRefused, Profile
from robotd.control.rpc import APP_ERROR, INVALID_PARAMS, RpcError
from robotd.control.server import Client, Handler


def profile_handlers(profile: Profile, ctx: RobotContext, core: Collection[str]
                     ) -> dict[str, Handler]:
    """The profile's methods as control handlers; ValueError for a badly named one."""
    handlers: dict[str, Handler] = {}
    for name, method in profile.control_methods(ctx).items():
        if not name.startswith(f"{profile.name}.") or name == f"{profile.name}.":
            msg = f"profile {profile.name}: control method {name!r} must be named " \
                  f"'{profile.name}.<method>'"
            raise ValueError(msg)
        if name in core:
            msg = f"profile {profile.name}: control method {name!r} shadows a core method"
            raise ValueError(msg)
        handlers[name] = _handler(name, method)
    return handlers


def _handler(name: str, method: ControlMethod) -> Handler:
    async def handle(params: dict[str, Any], _client: Client) -> Any:
        try:
            return await method(params)
        except ValueError as exc:
            raise RpcError(INVALID_PARAMS, f"{name}: {exc}") from exc
        except ControlRefused as exc:
            raise RpcError(APP_ERROR, f"{name}: {exc}") from exc
    return handle
