"""The simulated world: floor plan, robot body, geometry and the motor plant."""
