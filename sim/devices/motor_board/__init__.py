"""The simulated motor board: a fake MCU on the serial protocol, or the firmware in simavr."""
