"""`cart2d calibrate`: odometry calibration with UMBmark. arithmetic.py (the maths, pure),
runners.py (driving the square on a cart or in the simulator), procedure.py (the passes, the
geometry on the link), command.py (the command line)."""
