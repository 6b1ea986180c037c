"""The only code that imports Zenoh: sessions (session.py), the key layout (keys.py),
the wire format (codec.py) and a small request/publish API over a session (bus.py)."""
