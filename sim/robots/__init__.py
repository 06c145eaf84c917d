"""Each robot's simulator slice, one package a robot: scenarios, actors, checks, report layers."""
