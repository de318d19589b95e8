"""Container runtimes: the interface, the Docker sandbox, local processes, and what cleans up.

``interface`` (``AgentRuntime``), ``docker`` (``DockerRuntime``), ``local``
(``LocalProcessRuntime``), ``engine`` (the Docker client), ``cpus`` (core placement),
``reaper`` (heartbeats and stale agents), ``cleanup`` (``eagc cleanup``).
"""
