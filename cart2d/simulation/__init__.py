"""The simulated camera's Python side: the side channel's camera and target messages
(controls.py, mixed into cart2d.simulator.Simulator) and the ESP32-CAM URLs it is served at
(camera.py)."""
