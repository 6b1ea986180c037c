"""The control endpoint: the runtime's ``esair/<robot>/ctl/<verb>`` queryables
(control_server), the verbs for principals outside the deployment (observe), the
operator's sample/send (operator) and ``esair std ls``'s rows (listing)."""
