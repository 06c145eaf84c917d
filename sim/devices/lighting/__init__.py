"""The simulated camera's light and noise: floor texture, lens falloff, room light, sensor noise."""
