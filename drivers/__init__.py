"""Real device drivers on hal ports: Arduino link, camera, BLE, HX711, dock IR, LD19 LiDAR."""
