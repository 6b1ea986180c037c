"""Where components live: thread mode (one process), process mode (one OS process per
component, joined by Zenoh) and the component-host process (agent)."""
