"""What a new user reads (issue 31): a run with several robots names the robot in each log line
its tasks write; a vacuum's designed bumps are bumps, not collisions."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import pytest
import structlog

from robotd.cli import main
from sim.crash import DaemonKeeper
from sim.scenario import load_scenario


def _keeper(names: list[str]) -> DaemonKeeper:
    return DaemonKeeper(dict.fromkeys(names), {}, lambda _name: None, lambda _event: None)


class TestLogLinesNameTheRobot:
    def test_with_several_robots_a_robots_tasks_bind_its_name(self) -> None:
        keeper = _keeper(["laundry-1", "laundry-2"])
        bound = keeper.context_of("laundry-2").run(structlog.contextvars.get_contextvars)
        assert bound == {"robot": "laundry-2"}

    def test_with_one_robot_nothing_is_added(self) -> None:
        keeper = _keeper(["sim-1"])
        assert keeper.context_of("sim-1").run(structlog.contextvars.get_contextvars) == {}

    async def test_a_task_started_in_it_logs_with_the_name(self) -> None:
        keeper = _keeper(["a", "b"])
        seen: dict[str, Any] = {}

        async def work() -> None:
            seen.update(structlog.contextvars.get_contextvars())

        await asyncio.create_task(work(), context=keeper.context_of("a"))
        assert seen == {"robot": "a"}


class TestBumpsByDesign:
    def test_a_vacuums_bumps_are_not_collisions_and_the_report_names_run_mcap(
            self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """docking allows contact (a vacuum cleans by bumping into things): its figures say
        bumps; nav does not, and says collisions. The report line names run.mcap."""
        out = tmp_path / "out"
        assert main(["sim", "docking", "--report", str(out)]) == 0
        printed = capsys.readouterr().out
        figures = json.loads((out / "events.jsonl").read_text().splitlines()[-1])["figures"]
        assert figures["vac-1"]["bumps"] > 0 and "collisions" not in figures["vac-1"]
        assert f"{out}/run.mcap" in printed
        assert load_scenario("nav").success.no_collisions is True
