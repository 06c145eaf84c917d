"""The cabinet robot's mission steps: the shared state, the drive controller and each phase."""
