"""`cart2d camera calibrate`: views.py (the views to take and the calibration from them),
simulated.py (the simulator places the board: --sim), command.py (the command line)."""
