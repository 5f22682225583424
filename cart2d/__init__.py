"""cart2d: the gateway, planner and tools of the cart2d robot (the seed's ESP32, on Linux)."""

__version__ = "0.1.0"
