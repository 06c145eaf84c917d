"""hal/sim."""
