"""``robotd map``: recorded logs in, map_server maps and trajectories out."""
