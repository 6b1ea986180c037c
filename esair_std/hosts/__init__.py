"""The hosts of components: a behavior or reaction (behavior_host), a resource entry
(resource_host), and the component-host process that holds either in process mode
(agent_process)."""
