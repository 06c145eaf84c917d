"""The control socket's methods (DESIGN.md contract), served from the running daemon."""

from __future__ import annotations

import asyncio
import os
from typing import TYPE_CHECKING, Any

from robotd import __version__
from robotd.config.overrides import overrides_path, persist_override, render_toml
from robotd.config.screen import clip, read_option_text
from robotd.control.profile_methods import profile_handlers
from robotd.control.rpc import APP_ERROR, INVALID_PARAMS, RpcError
from robotd.control.server import Client, Handler
from robotd.control.teleop import Teleop

if TYPE_CHECKING:
    from robotd.daemon import Daemon

TOPICS = ("state", "events", "service", "estop", "link", "config", "tune", "behaviour", "*")
MAX_EVENTS = 1000


def control_handlers(daemon: Daemon) -> dict[str, Handler]:
    """Method name -> handler for the control server: the core's and the profile's own."""
    methods = _Methods(daemon)
    teleop = Teleop(daemon)

    async def drive(params: dict[str, Any], _client: Client) -> dict[str, Any]:
        return await teleop.drive(params)

    core: dict[str, Handler] = {
        "status": methods.status,
        "sensors": methods.sensors,
        "events": methods.events,
        "tune.get": methods.tune_get,
        "tune.set": methods.tune_set,
        "reload": methods.reload,
        "estop": methods.estop,
        "resume": methods.resume,
        "trigger": methods.trigger,
        "subscribe": methods.subscribe,
        "unsubscribe": methods.unsubscribe,
        "drive": drive,
    }
    return {**core, **profile_handlers(daemon.profile, daemon.context, core)}


def _mission(profile: object) -> dict[str, Any]:
    """``mission``: what a profile says of its mission (the cabinet robot's task list, path
    and broken links), when it says anything."""
    figures = getattr(profile, "mission_status", None)
    return {"mission": figures()} if callable(figures) else {}


class _Methods:
    def __init__(self, daemon: Daemon) -> None:
        self.d = daemon

    async def status(self, _params: dict[str, Any], _client: Client) -> dict[str, Any]:
        d = self.d
        motors = d.devices.motors
        return {
            "robot": d.settings.get("robot.name"),
            "profile": d.profile.name,
            "state": d.state,
            "estop": d.state == "estop" or d.context.estop_latch.latched,
            "estop_latch": d.context.estop_latch.record,
            "fault": _fault(d),
            "ready": d.ready.is_set(),
            "uptime_s": round(d.uptime_s, 3),
            "services": d.supervisor.status(),
            "loop_lag_ms": d.monitor.figures(),
            "link": None if motors is None else ("up" if motors.connected else "down"),
            "triggers": d.machine.allowed_triggers(),
            "config": d.settings.source,
            "clients": len(d.control.clients) if d.control else 0,
            "pid": os.getpid(),
            "version": __version__,
            **_mission(d.profile),
            **({} if d.step_cpu is None else {"slow_steps": d.step_cpu.figures()}),
        }

    async def sensors(self, _params: dict[str, Any], _client: Client) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for device in self.d.devices.distinct():
            name = str(getattr(device, "name", type(device).__name__))
            try:
                figures = dict(device.status())
            except Exception as exc:  # one broken device must not hide the others
                figures = {"error": repr(exc)}
            out[name] = figures
        navigation = getattr(self.d.profile, "status", None)
        if callable(navigation):  # a navigating profile: pose, spread, scan rate, plan
            out["navigation"] = navigation()
        return {"devices": out, "present": self.d.devices.present()}

    async def events(self, params: dict[str, Any], _client: Client) -> list[dict[str, Any]]:
        limit = params.get("limit", 50)
        if isinstance(limit, bool) or not isinstance(limit, int) or limit < 0:
            raise RpcError(INVALID_PARAMS, "limit: expected an integer >= 0")
        kind = params.get("kind")
        events = list(self.d.events)
        if kind is not None:
            events = [e for e in events if e["kind"] == kind]
        return events[-min(limit, MAX_EVENTS):] if limit else []

    async def tune_get(self, params: dict[str, Any], _client: Client) -> dict[str, Any]:
        key = _key(params)
        try:
            value = self.d.settings.get(key)
            option = self.d.settings.option(key)
        except KeyError as exc:
            raise RpcError(INVALID_PARAMS, str(exc.args[0])) from None
        return {"key": key, "value": value, "tunable": option.tunable, "help": option.help}

    async def tune_set(self, params: dict[str, Any], _client: Client) -> dict[str, Any]:
        key = _key(params)
        if "value" not in params:
            raise RpcError(INVALID_PARAMS, "missing param 'value'")
        persist = params.get("persist", False)
        if not isinstance(persist, bool):
            raise RpcError(INVALID_PARAMS, "persist: expected true or false")
        settings = self.d.settings
        try:
            option = settings.option(key)
        except KeyError as exc:
            raise RpcError(INVALID_PARAMS, str(exc.args[0])) from None
        if not option.tunable:
            raise RpcError(INVALID_PARAMS, f"{key}: cannot be tuned live (read at start); "
                           "change it in the config file and restart")
        value = params["value"]
        if isinstance(value, str) and option.kind != "str":
            value, error = read_option_text(value)
            if error is not None:
                raise RpcError(INVALID_PARAMS, f"{key}: {error}")
        try:
            checked = settings.check(key, value)
            if persist:
                render_toml({"check": {"value": checked.value}})  # refuse before applying
        except ValueError as exc:
            raise RpcError(INVALID_PARAMS, str(exc)) from None
        value = settings.apply(checked)
        if persist:
            path = overrides_path(self.d.state_dir)
            try:
                await asyncio.get_running_loop().run_in_executor(
                    None, persist_override, path, key, value)
            except OSError as exc:
                raise RpcError(APP_ERROR, f"{key}: applied but not persisted: {exc}") from None
            except (ValueError, RecursionError) as exc:  # the file is there but not TOML
                # Not overwritten: what it held is kept for whoever looks at it.
                raise RpcError(APP_ERROR, f"{key}: applied but not persisted: {path} cannot "
                               f"be read ({clip(str(exc))}); fix or remove it") from None
        self.d.emit("tune", key=key, value=value, persisted=persist)
        reply: dict[str, Any] = {"key": key, "value": value, "persisted": persist}
        if persist:
            reply["persisted_to"] = str(overrides_path(self.d.state_dir))
            if settings.get("hal.backend") == "sim":
                reply["note"] = ("the simulator's state directory is temporary: the value "
                                 "is gone when the run ends; put it in the scenario's [config] "
                                 "or a --config file to keep it")
        return reply

    async def reload(self, _params: dict[str, Any], _client: Client) -> dict[str, Any]:
        ok, lines = self.d.reload()
        if not ok:
            raise RpcError(APP_ERROR, "config not reloaded; the running config is kept",
                           {"problems": lines})
        return {"reloaded": True, "changed": lines, "source": self.d.settings.source}

    async def estop(self, params: dict[str, Any], _client: Client) -> dict[str, Any]:
        reason = params.get("reason", "robotctl estop")
        await self.d.estop(str(reason)[:200], source="robotctl")
        latch = self.d.context.estop_latch
        return {"state": self.d.state, "estop": self.d.state == "estop",
                "latched": latch.latched, "estop_latch": latch.record}

    async def resume(self, _params: dict[str, Any], _client: Client) -> dict[str, Any]:
        if not await self.d.machine.trigger("resume", source="robotctl"):
            raise RpcError(APP_ERROR, f"cannot resume: not in estop (state {self.d.state})")
        latch = self.d.context.estop_latch
        return {"state": self.d.state, "estop": latch.latched, "estop_latch": latch.record}

    async def trigger(self, params: dict[str, Any], _client: Client) -> dict[str, Any]:
        name = params.get("name")
        if not isinstance(name, str) or name not in self.d.machine.triggers:
            raise RpcError(INVALID_PARAMS, f"name: expected one of {self.d.machine.triggers}")
        ok = await self.d.machine.trigger(name)
        if not ok:
            raise RpcError(APP_ERROR, f"{name}: not allowed in state {self.d.state}")
        return {"state": self.d.state}

    async def subscribe(self, params: dict[str, Any], client: Client) -> dict[str, Any]:
        topics = _topics(params)
        client.topics.update(topics)
        return {"topics": sorted(client.topics)}

    async def unsubscribe(self, params: dict[str, Any], client: Client) -> dict[str, Any]:
        client.topics.difference_update(_topics(params))
        return {"topics": sorted(client.topics)}


def _key(params: dict[str, Any]) -> str:
    key = params.get("key")
    if not isinstance(key, str) or "." not in key or len(key) > 200:
        raise RpcError(INVALID_PARAMS, "key: expected 'section.key', e.g. 'line_follow.kp'")
    return key


def _topics(params: dict[str, Any]) -> list[str]:
    topics = params.get("topics")
    if not isinstance(topics, list) or not all(isinstance(t, str) for t in topics):
        raise RpcError(INVALID_PARAMS, f"topics: expected a list of names from {list(TOPICS)}")
    unknown = [t for t in topics if t not in TOPICS]
    if unknown:
        raise RpcError(INVALID_PARAMS, f"topics: unknown {unknown}; known: {list(TOPICS)}")
    return topics


def _fault(d: Daemon) -> dict[str, str] | None:
    """Why the robot is in recovery (``code``, ``message``), or None."""
    fault = d.context.fault
    return None if fault is None else {"code": fault.code, "message": fault.message}
