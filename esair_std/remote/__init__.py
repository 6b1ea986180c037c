"""ESAIR STD across computers: remote agents, their identity, robots joined."""
