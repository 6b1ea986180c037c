"""The board model: the frozen pydantic definitions of a board file (``board``), the
validator that turns a robot folder into one :class:`~esair_min.model.robot.Robot`
(``validate``), and what is computed from it (``hardware`` timing, EEPROM ``layout``,
the ``summary`` of ``esair check``).
"""
