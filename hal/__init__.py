"""Hardware abstraction layer: what behaviours see of the robot's devices."""
