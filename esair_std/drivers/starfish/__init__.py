"""STARFISH, the thesis's surveillance robot (5.1), on its Linux side: the room and the
robot's microphones, camera and radio in simulation, the bearing of a sound (GCC-PHAT)
and a path planner. See docs/std-starfish.md.

- ``room.py``: walls, landmarks, the sound source, rays and line of sight;
- ``mics.py``: the 4-channel 16 kHz microphone array rendered from the room;
- ``gccphat.py``: bearing and confidence from the microphones' frames;
- ``camera.py``: a 320x240 picture of the room from the robot's pose (Pillow);
- ``radio.py``: the link to the remote control center as a function of the pose;
- ``planner.py``: a path around the walls (A*);
- ``standin.py``: a stand-in world (pose from wheel commands) until STARFISH's emulator;
- ``driver.py``: ``Starfish``, the STD driver giving them as resources.
"""


def __getattr__(name: str) -> type:
    # the driver needs the runtime's classes: imported only when asked for, so the pure
    # computation (rendering, localization) works without them
    if name == "Starfish":
        from .driver import Starfish
        return Starfish
    raise AttributeError(name)
