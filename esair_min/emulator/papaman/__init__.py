"""PAPA-MAN's boards emulated: the central board over its actuator (servo) and sensor
boards on one virtual I2C bus (:class:`.robot_sim.Emulator`), its scenarios and live view."""
