"""Mapping: key scans matched against the growing map, a pose graph, the grid rendered."""
