"""`cart2d mission`: spec.py (the mission file and its report, checked before anything runs),
run.py (the run in a simulator of its own), events.py (map changes at simulated times),
camera.py (the simulated camera and perception), trace.py (what the run keeps of the stream)."""
