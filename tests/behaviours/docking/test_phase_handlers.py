"""Every sub-state a docking phase loop dispatches on has its handler, and every handler names a
sub-state of its phase (issue 26: ``run_phase`` idles on a sub-state it has no handler for,
so a misspelt name would sit until the phase's 60 s timeout)."""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any

import pytest

from behaviours.docking import tables
from behaviours.docking.capability import Docking
from behaviours.docking.senses import PhaseLoop, PhaseStep
from behaviours.docking.tables import DOCKING_TRANSITIONS, DockState, DockTrigger, docking_states
from behaviours.machine_tables import CORE_TRANSITIONS, CoreTrigger, RootState, state_paths

LOOPS = Docking.phase_loops()


def handler_problems(states: list[Any], loop: PhaseLoop) -> list[str]:
    """What is wrong between the sub-states of ``loop.phase`` in the children of ``docking``
    (``states``) and the handlers its loop dispatches to: a leaf without a callable
    handler, a handler keyed by anything but a leaf of that phase (it would never run)."""
    leaves = [p for p in state_paths(states, RootState.DOCKING, leaves_only=True)
              if p.startswith(loop.phase + ".")]
    problems = [f"{leaf}: no handler" for leaf in leaves
                if not callable(loop.handlers.get(leaf))]
    problems += [f"{key}: no such sub-state of {loop.phase}" for key in loop.handlers
                 if key not in leaves]
    return problems


def _constants(cls: type) -> dict[str, str]:
    return {k: v for k, v in vars(cls).items() if k.isupper()}


def _renamed(states: list[Any], path: str, new_name: str, prefix: str = "docking"
             ) -> list[Any]:
    """A deep copy of a states table with the state at ``path`` renamed (a typo in the table)."""
    out = copy.deepcopy(states)
    for i, item in enumerate(out):
        name = item if isinstance(item, str) else item["name"]
        here = f"{prefix}.{name}"
        if here == path:
            if isinstance(item, str):
                out[i] = new_name
            else:
                item["name"] = new_name
        elif isinstance(item, dict) and path.startswith(here + "."):
            item["children"] = _renamed(item["children"], path, new_name, here)
    return out


async def _step(_ctx: Any, _senses: Any) -> None:
    return None


class TestEveryLeafHasItsHandler:
    @pytest.mark.parametrize("loop", LOOPS, ids=[loop.phase for loop in LOOPS])
    def test_each_phase_loop_covers_its_sub_states_exactly(self, loop: PhaseLoop) -> None:
        assert handler_problems(docking_states(), loop) == []

    def test_every_phase_with_sub_states_is_run_by_a_loop(self) -> None:
        """A phase with children whose task is not a phase loop would have no handler at all
        for them: every such phase of the table is one of ``Docking.phase_loops()``."""
        phases = {f"docking.{s['name']}" for s in docking_states()
                  if isinstance(s, dict) and s.get("children")}
        assert phases == {loop.phase for loop in LOOPS}

    def test_the_loops_are_the_phase_tasks_of_the_capability(self) -> None:
        """Each loop's phase has a state task, so the machine starts it on entering."""
        tasks = Docking(lambda: None).state_tasks()
        assert {loop.phase for loop in LOOPS} <= set(tasks)

    def test_there_are_46_leaves_in_the_loops(self) -> None:
        """The count issue 26 names: the seed's sub-steps and position cases."""
        assert sum(len(loop.handlers) for loop in LOOPS) == 46


class TestTheCheckFails:
    """``handler_problems`` reports each way a leaf and its handler can part."""

    def test_a_misspelt_leaf_in_the_table(self) -> None:
        states = _renamed(docking_states(), DockState.WALL_FOLLOW, "wall_folow")
        search = next(loop for loop in LOOPS if loop.phase == DockState.SEARCH)
        assert handler_problems(states, search) == [
            "docking.search.wall_folow: no handler",
            "docking.search.wall_follow: no such sub-state of docking.search"]

    def test_a_misspelt_nested_leaf_in_the_table(self) -> None:
        states = _renamed(docking_states(), DockState.OVERLAP_L, "overlap_1")
        position = next(loop for loop in LOOPS if loop.phase == DockState.POSITION)
        assert handler_problems(states, position) == [
            "docking.position.left_approach.overlap_1: no handler",
            "docking.position.left_approach.overlap_l: no such sub-state of docking.position"]

    @pytest.mark.parametrize(("drop", "add", "expected"), [
        (DockState.RETRY, None, ["docking.dock.retry: no handler"]),
        (None, "docking.dock.motor_stopp", ["docking.dock.motor_stopp: no such sub-state of "
                                            "docking.dock"]),
        (None, DockState.BALANCED, ["docking.align.balanced: no such sub-state of "
                                    "docking.dock"]),
        (None, DockState.DOCK, ["docking.dock: no such sub-state of docking.dock"]),
    ], ids=["missing", "misspelt", "another_phase", "the_phase_itself"])
    def test_a_handler_dict_that_parts_from_the_table(self, drop: str | None, add: str | None,
                                                      expected: list[str]) -> None:
        dock = next(loop for loop in LOOPS if loop.phase == DockState.DOCK)
        handlers: dict[str, PhaseStep] = {k: v for k, v in dock.handlers.items() if k != drop}
        if add is not None:
            handlers[add] = _step
        assert handler_problems(docking_states(), PhaseLoop(dock.phase, handlers)) == expected

    def test_a_handler_that_is_not_callable(self) -> None:
        dock = next(loop for loop in LOOPS if loop.phase == DockState.DOCK)
        handlers: Mapping[str, Any] = {**dock.handlers, DockState.RETRY: None}
        assert handler_problems(docking_states(), PhaseLoop(dock.phase, handlers)) == [
            "docking.dock.retry: no handler"]


class TestTheConstants:
    def test_every_state_constant_is_a_state_of_the_table(self) -> None:
        """A constant whose value is misspelt names no state (the table nests by the path)."""
        paths = {RootState.DOCKING, *state_paths(docking_states(), RootState.DOCKING)}
        assert sorted(set(_constants(DockState).values()) - paths) == []
        assert sorted(paths - set(_constants(DockState).values())) == []

    def test_every_trigger_constant_is_a_trigger_of_the_table_and_back(self) -> None:
        named = set(_constants(DockTrigger).values())
        used = {t["trigger"] for t in DOCKING_TRANSITIONS}
        core = {t["trigger"] for t in CORE_TRANSITIONS}
        assert sorted(named - used) == []
        assert sorted(used - named - core) == []
        assert sorted(set(_constants(CoreTrigger).values()) - core) == []

    def test_a_state_nested_under_the_wrong_parent_is_refused(self) -> None:
        with pytest.raises(ValueError, match=r"not a child of 'docking\.search'"):
            tables._nest(DockState.SEARCH, [DockState.WALL_FOLLOW, DockState.RETRY])
