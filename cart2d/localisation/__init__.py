"""Where the cart is in `map`: AprilTag markers at surveyed places (markers.py), their sightings
and the pose each gives (tags.py), and the filter that fuses them with odometry (ekf.py)."""
