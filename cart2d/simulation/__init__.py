"""The simulator, outside the gateway: the cart2d-sim process (simulator.py, its side channel
side_channel.py), its camera and target (controls.py, camera.py, lockstep.py), its faults and
world files (faults.py, world_file.py), the boxes of its world (world.py) and their routes
(routes.py), the firmware flashed through its Optiboot (bootloader.py), and the supervisor that
starts it again when it exits on its own (supervisor.py). Only `cart2d sim` and `cart2d mission`
wire it in (wiring.py): the gateway sees a Link, a source of ground truth and a simulated world."""
