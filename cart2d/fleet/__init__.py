"""The fleet: each gateway a VDA 5050 vehicle on an MQTT broker (vehicle.py), and the fleet
manager that gives carts their orders and keeps them apart (manager.py, traffic.py)."""
