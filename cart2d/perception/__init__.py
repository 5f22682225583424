"""The cart's camera on the gateway: the MJPEG reader, the camera model and its calibration,
obstacle detection on the floor and the occupancy grid it feeds."""
