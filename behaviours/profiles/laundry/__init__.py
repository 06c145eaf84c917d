"""The laundry robot (seed 000, robot side): line following between rooms, beacons, weight."""
