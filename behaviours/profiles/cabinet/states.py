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

from typing import Any, Final

from behaviours.machine_tables import CoreTrigger, RootState

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


class CabinetState:
    """Every mission state's dotted path (the names in logs, events and tests).

    Plain ``str`` constants (``transitions`` would take an Enum state by its member name).
    """

    INIT: Final = "mission.init"
    TASK_MANAGER: Final = "mission.init.task_manager"
    PERCEPTOR: Final = "mission.init.perceptor"
    PATH_PLANNER: Final = "mission.init.path_planner"
    DRIVE_CONTROLLER: Final = "mission.init.drive_controller"
    FITTING: Final = "mission.fitting"
    FIT: Final = "mission.fitting.fit"
    CHANGE_ORIENTATION: Final = "mission.fitting.change_orientation"
    DRIVE: Final = "mission.fitting.drive"
    GO_ROOM_MIDDLE: Final = "mission.fitting.go_room_middle"
    RELOCATE: Final = "mission.relocate"
    CREATE_PATH: Final = "mission.relocate.create_path"
    PROCEED_PATH: Final = "mission.relocate.proceed_path"
    DRIVE_TO_NODE: Final = "mission.relocate.drive_to_node"
    BREAK_LINK: Final = "mission.relocate.break_link"
    RESET_LINKS: Final = "mission.relocate.reset_links"
    ACTION: Final = "mission.cabinet_action"
    FACE_FRONT: Final = "mission.cabinet_action.face_front"
    APPROACH: Final = "mission.cabinet_action.approach"
    ACT: Final = "mission.cabinet_action.act"
    REPORT: Final = "mission.cabinet_action.report"
    BACK_OFF: Final = "mission.cabinet_action.back_off"
    FAILED: Final = "mission.failed"


class CabinetTrigger:
    """The triggers of the cabinet robot's transitions (``timeout`` and ``mission_done`` are
    the core's)."""

    # Init.
    TASKS_READ: Final = "tasks_read"
    MAP_READ: Final = "map_read"
    GRAPH_BUILT: Final = "graph_built"
    CONTROLLERS_READY: Final = "controllers_ready"
    INIT_FAILED: Final = "init_failed"
    # Fitting.
    FITTED: Final = "fitted"
    NO_FIT: Final = "no_fit"
    FULL_TURN: Final = "full_turn"
    NO_FIT_ANYWHERE: Final = "no_fit_anywhere"
    ORIENTATION_SET: Final = "orientation_set"
    ROOM_MIDDLE_SET: Final = "room_middle_set"
    DRIVEN: Final = "driven"
    # Relocate.
    PATH_FOUND: Final = "path_found"
    NO_PATH_LINKS_BROKEN: Final = "no_path_links_broken"
    NO_PATH: Final = "no_path"
    NEXT_NODE: Final = "next_node"
    PATH_DONE: Final = "path_done"
    NODE_REACHED: Final = "node_reached"
    BLOCKED: Final = "blocked"
    LOST_POSE: Final = "lost_pose"
    LINK_BROKEN: Final = "link_broken"
    LINKS_RESET: Final = "links_reset"
    RESET_LIMIT: Final = "reset_limit"
    # Cabinet action.
    FACED: Final = "faced"
    AT_STANDOFF: Final = "at_standoff"
    ACTED: Final = "acted"
    REPORTED: Final = "reported"
    NEXT_TASK: Final = "next_task"
    SKIP_TASK: Final = "skip_task"
    ACKNOWLEDGED: Final = "acknowledged"


S, T = CabinetState, CabinetTrigger


def _name(path: str) -> str:
    return path.rpartition(".")[2]


def _phase(path: str, timeouts: dict[str, float]) -> dict[str, Any]:
    """A phase of steps, the first its initial one; each step with its named timeout."""
    steps = [{"name": _name(step), "timeout": timeout_s, "on_timeout": "timed_out"}
             for step, timeout_s in timeouts.items()]
    for step in timeouts:
        if step.rpartition(".")[0] != path:
            msg = f"cabinet table: {step!r} is not a step of {path!r}"
            raise ValueError(msg)
    return {"name": _name(path), "initial": steps[0]["name"], "children": steps}


def cabinet_states() -> list[str | dict[str, Any]]:
    """The mission's children: the seed's phases and cases, each with its named timeout."""
    return [
        _phase(S.INIT, dict.fromkeys((S.TASK_MANAGER, S.PERCEPTOR, S.PATH_PLANNER,
                                      S.DRIVE_CONTROLLER), INIT_STEP_TIMEOUT_S)),
        _phase(S.FITTING, {S.FIT: FIT_TIMEOUT_S, S.CHANGE_ORIENTATION: TURN_TIMEOUT_S,
                           S.DRIVE: DRIVE_TIMEOUT_S, S.GO_ROOM_MIDDLE: TURN_TIMEOUT_S}),
        _phase(S.RELOCATE, {S.CREATE_PATH: PLAN_TIMEOUT_S, S.PROCEED_PATH: PLAN_TIMEOUT_S,
                            S.DRIVE_TO_NODE: DRIVE_TO_NODE_TIMEOUT_S,
                            S.BREAK_LINK: PLAN_TIMEOUT_S, S.RESET_LINKS: PLAN_TIMEOUT_S}),
        _phase(S.ACTION, {S.FACE_FRONT: CABINET_STEP_TIMEOUT_S,
                          S.APPROACH: CABINET_STEP_TIMEOUT_S, S.ACT: ACTION_TIMEOUT_S,
                          S.REPORT: CABINET_STEP_TIMEOUT_S, S.BACK_OFF: CABINET_STEP_TIMEOUT_S}),
        {"name": _name(S.FAILED), "on_enter": "stop_motors"},
    ]


def _t(trigger: str, source: str | list[str], dest: str) -> dict[str, Any]:
    return {"trigger": trigger, "source": source, "dest": dest}


def cabinet_transitions() -> list[dict[str, Any]]:
    """Every move between the steps; a timeout of a step goes where its failure would."""
    timeout = CoreTrigger.TIMEOUT
    init_steps = [S.TASK_MANAGER, S.PERCEPTOR, S.PATH_PLANNER, S.DRIVE_CONTROLLER]
    return [
        # Init: the four blocks in the seed's order, then fitting; a bad file fails the mission.
        _t(T.TASKS_READ, S.TASK_MANAGER, S.PERCEPTOR),
        _t(T.MAP_READ, S.PERCEPTOR, S.PATH_PLANNER),
        _t(T.GRAPH_BUILT, S.PATH_PLANNER, S.DRIVE_CONTROLLER),
        _t(T.CONTROLLERS_READY, S.DRIVE_CONTROLLER, S.FIT),
        _t(T.INIT_FAILED, init_steps, S.FAILED),
        _t(timeout, init_steps, S.FAILED),
        # Fitting: case 1 fit; on failure case 2 (turn by cabinet.change_orientation_deg) and
        # case 3 drive, then fit again; after a full turn case 4 (the room's middle) and
        # case 3; after a full turn there too, recovery with the best score in the reason.
        _t(T.FITTED, S.FIT, S.CREATE_PATH),
        _t(T.NO_FIT, S.FIT, S.CHANGE_ORIENTATION),
        _t(T.FULL_TURN, S.FIT, S.GO_ROOM_MIDDLE),
        _t(T.NO_FIT_ANYWHERE, S.FIT, RootState.RECOVERY),
        _t(timeout, S.FIT, S.CHANGE_ORIENTATION),
        _t(T.ORIENTATION_SET, S.CHANGE_ORIENTATION, S.DRIVE),
        _t(T.ROOM_MIDDLE_SET, S.GO_ROOM_MIDDLE, S.DRIVE),
        _t(T.DRIVEN, S.DRIVE, S.FIT),
        _t(timeout, [S.CHANGE_ORIENTATION, S.DRIVE, S.GO_ROOM_MIDDLE], S.FIT),
        # Relocate: case 1 A* over the open links; case 2 the next node; case 3 drive to it;
        # case 4 a blocked link is broken (event link.closed) and the path made again; case 5
        # no path while links are broken: reset them (bounded) and plan again.
        _t(T.PATH_FOUND, S.CREATE_PATH, S.PROCEED_PATH),
        _t(T.NO_PATH_LINKS_BROKEN, S.CREATE_PATH, S.RESET_LINKS),
        _t(T.NO_PATH, S.CREATE_PATH, S.FAILED),
        _t(T.NEXT_NODE, S.PROCEED_PATH, S.DRIVE_TO_NODE),
        _t(T.PATH_DONE, S.PROCEED_PATH, S.FACE_FRONT),
        _t(T.NODE_REACHED, S.DRIVE_TO_NODE, S.PROCEED_PATH),
        _t(T.BLOCKED, S.DRIVE_TO_NODE, S.BREAK_LINK),
        _t(timeout, S.DRIVE_TO_NODE, S.BREAK_LINK),
        _t(T.LOST_POSE, S.DRIVE_TO_NODE, S.FIT),
        _t(T.LINK_BROKEN, S.BREAK_LINK, S.CREATE_PATH),
        _t(T.LINKS_RESET, S.RESET_LINKS, S.CREATE_PATH),
        _t(T.RESET_LIMIT, S.RESET_LINKS, S.FAILED),
        _t(timeout, [S.CREATE_PATH, S.PROCEED_PATH, S.BREAK_LINK, S.RESET_LINKS], S.FAILED),
        # Cabinet action: face the front, approach to the LiDAR-measured standoff, act,
        # report cabinet.arrived with the pose error, back off; then the next task or idle.
        _t(T.FACED, S.FACE_FRONT, S.APPROACH),
        _t(T.AT_STANDOFF, S.APPROACH, S.ACT),
        _t(T.ACTED, S.ACT, S.REPORT),
        _t(T.REPORTED, S.REPORT, S.BACK_OFF),
        _t(T.NEXT_TASK, S.BACK_OFF, S.CREATE_PATH),
        _t(T.SKIP_TASK, S.CREATE_PATH, S.CREATE_PATH),
        _t(timeout, [S.FACE_FRONT, S.APPROACH, S.BACK_OFF], S.FAILED),
        _t(timeout, S.ACT, S.REPORT),
        _t(timeout, S.REPORT, S.BACK_OFF),
        _t(T.ACKNOWLEDGED, S.FAILED, RootState.IDLE),
    ]
