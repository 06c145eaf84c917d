"""The cabinet robot's ``robotctl links`` and ``reset-links``: its node graph, read and reset.

``links`` asks ``cabinet.links`` (every link as ``[a, b, length_m, open]``, the broken ones,
the resets this task) and prints the broken links first, then every link; ``reset-links``
asks ``cabinet.reset_links`` (a technician's reset: not counted against the task's
``max_link_resets``) and says how many it opened.
"""

from __future__ import annotations

from typing import Any

from behaviours.profile import CtlCommand, Table

LINKS_METHOD = "cabinet.links"
RESET_METHOD = "cabinet.reset_links"


def render_links(result: dict[str, Any], table: Table) -> str:
    """The broken links and every link, open or broken, as tables."""
    links = result.get("links") or []
    broken = result.get("broken") or []
    opened = sum(1 for link in links if len(link) > 3 and link[3])
    head = (f"{len(links)} links: {opened} open, {len(links) - opened} broken; "
            f"resets this task: {result.get('resets_this_task', 0)}\n")
    if broken:
        head += "broken: " + ", ".join(f"{a} - {b}" for a, b in broken) + "\n"
    else:
        head += "broken: none\n"
    rows = [[a, b, f"{float(length):.2f}", "open" if is_open else "BROKEN"]
            for a, b, length, is_open in (tuple(link[:4]) for link in links)]
    if not rows:
        return head
    return head + "\n" + table(["from", "to", "length_m", "link"], rows)


def render_reset(result: dict[str, Any], _table: Table) -> str:
    """How many broken links the reset opened."""
    opened = int(result.get("opened", 0))
    if not opened:
        return "no broken links: nothing to open\n"
    return f"opened {opened} broken link{'s' if opened != 1 else ''} (by hand: not counted " \
           "against the task's max_link_resets)\n"


COMMANDS = (
    CtlCommand("links", "cabinet robot: its node graph's links, the broken ones first",
               LINKS_METHOD, render=render_links),
    CtlCommand("reset-links", "cabinet robot: open every broken link (a technician's reset, "
               "not counted against the task's max_link_resets)", RESET_METHOD,
               render=render_reset),
)
