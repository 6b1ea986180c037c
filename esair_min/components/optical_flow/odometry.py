"""Dead reckoning from the flow sensors' summed counts: :mod:`esair_min.core.odometry`
(a leaf the robot side imports without the board model), named here with its kind."""

from esair_min.core.odometry import FlowOdometry, _det, _solve3, parse_odometry

__all__ = ["FlowOdometry", "_det", "_solve3", "parse_odometry"]
