"""Navigating a known map: grids, distance field, planning, following, localisation."""
