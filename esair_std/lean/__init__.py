"""The lean robot side of ``esair std run`` (docs/std.md, "A robot side without
pydantic"): the deployment is checked in a short-lived child process (pydantic, YAML,
the board models, every class and its options, errors at file:line, all as
``esair std check`` does), which hands back a plain-JSON deployment; a cache keyed by
the hash of every file read makes a second start skip that child. The robot side's
process then imports none of pydantic, yaml, jinja2 or esair_min.model.

This package imports nothing of :mod:`esair_std.deploy` at module level (that package
is the checker, pydantic); only the child does.
"""
