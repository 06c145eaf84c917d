"""Where the robot is on the map, and who is around it: MCL fused with odometry, people.

Monte Carlo localisation fused with wheel odometry (``filter``, ``service``), and people in the
LiDAR scan (``people``)."""
