"""The simulator runner: scenarios, the rig of simulated devices, the script, checks and report."""
