"""The platform-independent Python core and its protocol: the command ``decoder``, the
central board's ``central`` core, the frame ``player`` and balance reaction, the
EEPROM ``image``, event ``trace`` files, the simulated I2C ``devices`` and the stimulus
script ``harness``. The generated C core is its twin, checked trace for trace.
"""
