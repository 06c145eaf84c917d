"""Hardware abstraction: device Protocols and readings, ports, the settings view, loop time."""
