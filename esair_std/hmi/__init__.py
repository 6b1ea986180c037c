"""The remote control center in a browser (``esair std hmi``, docs/hmi.md).

- :mod:`.robotinfo`: what the page needs to know of a MIN robot, from its board files;
- :mod:`.bridge`: the runtime side: one Zenoh session to the control endpoint, the
  principal ``hmi`` watching sensors and sending commands through the RS and the AC;
- :mod:`.auth`: logins (hashed passwords) and roles (viewer, operator);
- :mod:`.commanded`: what the robot was last told (``PoseBook``): the pose the pages show;
- :mod:`.server`: the web side (the ``websockets`` library: static files and the
  WebSocket on one port), the fan-out to browsers;
- ``static/``: the page (plain HTML and JS modules: the feet's strip chart its own,
  ``strip.js``; uPlot vendored for the generic panels' plots).
"""
