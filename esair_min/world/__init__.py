"""A small 2-D world for emulated robots: a room of wall segments with landmarks, and a
robot body whose pose (x, y, theta) is integrated from its body velocity.

The API (other emulated devices, a microphone array or a camera, build on it):

- :class:`Room` — ``walls`` (tuple of :class:`Segment`, mm), ``landmarks`` (tuple of
  :class:`Landmark`); :meth:`Room.box` and :meth:`Room.default` make rooms,
  :func:`load_room` reads a small YAML file; :meth:`Room.ray` casts a ray to the
  nearest wall, :meth:`Room.clearance` is the distance from a point to the nearest wall.
- :class:`Pose` — ``x``, ``y`` in mm, ``theta`` in rad (counter-clockwise from +x);
  :meth:`Pose.to_world` maps a point of the robot's frame into the room.
- :class:`World` — a room and a round robot body: ``step(dt_s, vx, vy, omega)`` moves
  the body by its velocity in the robot's own frame (mm/s, mm/s, rad/s) for ``dt_s``
  seconds of virtual time and returns a :class:`Step` (the motion actually made, and
  whether a wall stopped it). Optional motor lag (first-order, ``lag_s``) and wheel
  slip (a fraction of the commanded motion lost, with seeded noise) are
  :class:`WorldOptions`. The world keeps no wall-clock time and no global state.

Units: mm, rad, seconds of virtual time, everywhere.
"""

from esair_min.world.room import Landmark, Room, Segment, load_room
from esair_min.world.body import Pose, Step, World, WorldOptions

__all__ = ["Landmark", "Pose", "Room", "Segment", "Step", "World", "WorldOptions", "load_room"]
