"""The square profile: a 1 m square on wheel odometry (a demonstration and a test)."""
