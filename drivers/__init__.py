"""Real device drivers, written against hal ports: Arduino link, camera, BLE, HX711."""
