"""Example deployments shipped with ESAIR STD (package data): ``lab`` runs every class
with simulated drivers, ``papaman`` the MIN robot over its serial link. ``esair std run
lab`` finds them by name (esair_std.deploy.bundled)."""
