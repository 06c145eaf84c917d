"""The cabinet robot (seed cabinet-robot-task-phases.md): its JSON site map, task list, node
graph and state table. Not registered as a profile yet: its mission tasks need the
simulator's navigation (issue 18, next step)."""
