"""The cart on ROS 2: its topics, frames, services and goals on DDS (Cyclone DDS), for Nav2, RViz
and teleop, without a ROS install (docs/ros2/). A subscriber of the gateway's events that never
holds up the control path: bridge.py."""
