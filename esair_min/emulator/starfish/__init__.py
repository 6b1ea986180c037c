"""STARFISH's boards emulated in a 2-D room: the central board, the drive board and the
flow sensors (:class:`.robot_sim.StarfishSim`), its fused tick, trace, view and launch."""
