"""Moving the body: wheel odometry, waypoint driving and the obstacle guard."""
