"""The simulator below the drivers: the virtual-time loop, the world, and simulated devices."""
