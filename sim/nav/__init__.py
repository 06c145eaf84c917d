"""The simulator's navigation parts: the robot's map from the world, the checks, the report."""
