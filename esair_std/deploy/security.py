"""The deployment's optional ``security:`` section (transport security).

A placeholder owned by the network part of STD (TLS/mTLS, user/password, ACL): it
accepts any mapping for now and keeps it as given; the transport reads it. Replace
this class with the real model -- the loader and ``esair std schema`` pick it up.
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict


class SecuritySpec(BaseModel):
    """Transport security of the runtime's sessions (fields defined by the transport)."""

    model_config = ConfigDict(extra="allow", frozen=True)
