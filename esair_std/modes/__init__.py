"""Where components live: thread mode (one process) and process mode (one OS process per
component, joined by Zenoh). The hosts they start are in :mod:`esair_std.hosts`."""
