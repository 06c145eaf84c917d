"""Following a painted line with the camera: the row scan, the tracker and the 13 FPS loop."""
