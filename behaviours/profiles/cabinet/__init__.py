"""The cabinet robot's site map, task list, node graph and state table (seed cabinet).

Not registered as a profile yet: its mission tasks need the simulator's navigation (issue 18,
next step). The formats and choices are in ``docs/cabinet.md``.
"""
