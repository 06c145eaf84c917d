"""The cabinet robot's mission states and transitions as data (seed cabinet-robot-task-phases).

The seed's phases nest under ``mission`` with its names: ``init`` (the four blocks as steps),
``fitting`` (cases 1-4), ``relocate`` (cases 1-5), ``cabinet_action`` (which the seed leaves
empty; defined here, see ``docs/cabinet.md``) and ``failed``. Each step is a state whose task
(started on enter, cancelled on exit) fires one of the step's triggers below; decisions (is
a link broken, is the reset budget spent, are tasks left) are made by that task, so the
table needs no conditions. State paths are relative to ``mission`` in ``cabinet_states`` and
absolute (``mission.relocate.break_link``) in the transitions.
"""

from __future__ import annotations

from typing import Any

INIT_STEP_TIMEOUT_S = 10.0
"""Reading files, building the grid and the graph: seconds on a Pi, never minutes."""
FIT_TIMEOUT_S = 10.0
"""One scan fit (global: about 0.2 s on a desktop, a few on a Pi) with the scan's wait."""
TURN_TIMEOUT_S = 20.0
"""A change of orientation (case 2 + 3) or a drive to the room's middle (case 4 + 3) ..."""
DRIVE_TIMEOUT_S = 60.0
"""... and fitting's drive case."""
PLAN_TIMEOUT_S = 5.0
"""A* over a graph of tens of nodes."""
DRIVE_TO_NODE_TIMEOUT_S = 180.0
"""A backstop only: ``cabinet.blocked_s`` without progress ends the drive much sooner."""
CABINET_STEP_TIMEOUT_S = 30.0
"""Facing the front, the approach, the report, the back-off."""
ACTION_TIMEOUT_S = 60.0
"""The configured action (open a latch, announce, take a snapshot)."""

INIT = "mission.init"
FITTING = "mission.fitting"
RELOCATE = "mission.relocate"
ACTION = "mission.cabinet_action"
FAILED = "mission.failed"

INIT_STEPS = ("task_manager", "perceptor", "path_planner", "drive_controller")
FITTING_CASES = ("fit", "change_orientation", "drive", "go_room_middle")
RELOCATE_CASES = ("create_path", "proceed_path", "drive_to_node", "break_link", "reset_links")
ACTION_STEPS = ("face_front", "approach", "act", "report", "back_off")


def _steps(names: tuple[str, ...], timeouts: dict[str, float]) -> list[dict[str, Any]]:
    return [{"name": n, "timeout": timeouts[n], "on_timeout": "timed_out"} for n in names]


def cabinet_states() -> list[str | dict[str, Any]]:
    """The mission's children: the seed's phases and cases, each with its named timeout."""
    return [
        {"name": "init", "initial": INIT_STEPS[0],
         "children": _steps(INIT_STEPS, dict.fromkeys(INIT_STEPS, INIT_STEP_TIMEOUT_S))},
        {"name": "fitting", "initial": "fit", "children": _steps(FITTING_CASES, {
            "fit": FIT_TIMEOUT_S, "change_orientation": TURN_TIMEOUT_S,
            "drive": DRIVE_TIMEOUT_S, "go_room_middle": TURN_TIMEOUT_S})},
        {"name": "relocate", "initial": "create_path", "children": _steps(RELOCATE_CASES, {
            "create_path": PLAN_TIMEOUT_S, "proceed_path": PLAN_TIMEOUT_S,
            "drive_to_node": DRIVE_TO_NODE_TIMEOUT_S, "break_link": PLAN_TIMEOUT_S,
            "reset_links": PLAN_TIMEOUT_S})},
        {"name": "cabinet_action", "initial": "face_front", "children": _steps(ACTION_STEPS, {
            "face_front": CABINET_STEP_TIMEOUT_S, "approach": CABINET_STEP_TIMEOUT_S,
            "act": ACTION_TIMEOUT_S, "report": CABINET_STEP_TIMEOUT_S,
            "back_off": CABINET_STEP_TIMEOUT_S})},
        {"name": "failed", "on_enter": "stop_motors"},
    ]


def _t(trigger: str, source: str | list[str], dest: str) -> dict[str, Any]:
    return {"trigger": trigger, "source": source, "dest": dest}


def _all(phase: str, names: tuple[str, ...]) -> list[str]:
    return [f"{phase}.{n}" for n in names]


def cabinet_transitions() -> list[dict[str, Any]]:
    """Every move between the steps; a timeout of a step goes where its failure would."""
    i, f, r, a = INIT, FITTING, RELOCATE, ACTION
    return [
        # Init: the four blocks in the seed's order, then fitting; a bad file fails the mission.
        _t("tasks_read", f"{i}.task_manager", f"{i}.perceptor"),
        _t("map_read", f"{i}.perceptor", f"{i}.path_planner"),
        _t("graph_built", f"{i}.path_planner", f"{i}.drive_controller"),
        _t("controllers_ready", f"{i}.drive_controller", f"{f}.fit"),
        _t("init_failed", _all(i, INIT_STEPS), FAILED),
        _t("timeout", _all(i, INIT_STEPS), FAILED),
        # Fitting: case 1 fit; on failure case 2 (turn by cabinet.change_orientation_deg) and
        # case 3 drive, then fit again; after a full turn case 4 (the room's middle) and
        # case 3; after a full turn there too, recovery with the best score in the reason.
        _t("fitted", f"{f}.fit", f"{r}.create_path"),
        _t("no_fit", f"{f}.fit", f"{f}.change_orientation"),
        _t("full_turn", f"{f}.fit", f"{f}.go_room_middle"),
        _t("no_fit_anywhere", f"{f}.fit", "recovery"),
        _t("timeout", f"{f}.fit", f"{f}.change_orientation"),
        _t("orientation_set", f"{f}.change_orientation", f"{f}.drive"),
        _t("room_middle_set", f"{f}.go_room_middle", f"{f}.drive"),
        _t("driven", f"{f}.drive", f"{f}.fit"),
        _t("timeout", [f"{f}.change_orientation", f"{f}.drive", f"{f}.go_room_middle"],
           f"{f}.fit"),
        # Relocate: case 1 A* over the open links; case 2 the next node; case 3 drive to it;
        # case 4 a blocked link is broken (event link.closed) and the path made again; case 5
        # no path while links are broken: reset them (bounded) and plan again.
        _t("path_found", f"{r}.create_path", f"{r}.proceed_path"),
        _t("no_path_links_broken", f"{r}.create_path", f"{r}.reset_links"),
        _t("no_path", f"{r}.create_path", FAILED),
        _t("next_node", f"{r}.proceed_path", f"{r}.drive_to_node"),
        _t("path_done", f"{r}.proceed_path", f"{a}.face_front"),
        _t("node_reached", f"{r}.drive_to_node", f"{r}.proceed_path"),
        _t("blocked", f"{r}.drive_to_node", f"{r}.break_link"),
        _t("timeout", f"{r}.drive_to_node", f"{r}.break_link"),
        _t("lost_pose", f"{r}.drive_to_node", f"{f}.fit"),
        _t("link_broken", f"{r}.break_link", f"{r}.create_path"),
        _t("links_reset", f"{r}.reset_links", f"{r}.create_path"),
        _t("reset_limit", f"{r}.reset_links", FAILED),
        _t("timeout", [f"{r}.create_path", f"{r}.proceed_path", f"{r}.break_link",
                       f"{r}.reset_links"], FAILED),
        # Cabinet action: face the front, approach to the LiDAR-measured standoff, act,
        # report cabinet.arrived with the pose error, back off; then the next task or idle.
        _t("faced", f"{a}.face_front", f"{a}.approach"),
        _t("at_standoff", f"{a}.approach", f"{a}.act"),
        _t("acted", f"{a}.act", f"{a}.report"),
        _t("reported", f"{a}.report", f"{a}.back_off"),
        _t("next_task", f"{a}.back_off", f"{r}.create_path"),
        _t("skip_task", f"{r}.create_path", f"{r}.create_path"),
        _t("timeout", [f"{a}.face_front", f"{a}.approach", f"{a}.back_off"], FAILED),
        _t("timeout", f"{a}.act", f"{a}.report"),
        _t("timeout", f"{a}.report", f"{a}.back_off"),
        _t("acknowledged", FAILED, "idle"),
    ]
