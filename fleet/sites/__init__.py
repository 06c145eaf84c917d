"""Example site files for robotd-fleet (package data)."""
