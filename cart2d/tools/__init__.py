"""The command-line tools: `cart2d` and its subcommands, apart from the library they use.

cli.py wires the subcommands (cart2d.entry runs it); live.py runs the gateway (`sim`, `serve`);
missions/ (`mission`), umbmark/ (`calibrate`: odometry), camera_calibration/ (`camera
calibrate`), replay.py (`replay`); cli_args.py and recording_args.py: options they share."""
