"""The live view and recordings: robots' telemetry as Foxglove channels, served and in MCAP."""
