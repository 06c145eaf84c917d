"""The example site (two rooms and a hall, three doors, four cabinets) as a JSON document
tests can change."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

EXAMPLES = Path(__file__).parents[4] / "behaviours" / "profiles" / "cabinet" / "examples"


def site_doc() -> dict[str, Any]:
    doc: dict[str, Any] = json.loads((EXAMPLES / "site.json").read_text())
    return copy.deepcopy(doc)


def tasks_doc() -> dict[str, Any]:
    doc: dict[str, Any] = json.loads((EXAMPLES / "tasks.json").read_text())
    return doc
