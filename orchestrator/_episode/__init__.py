"""One episode: the worker, collecting ``/output``, replay, and the team's agent check.

``worker`` (``run_episode``), ``collect`` (``/output`` read safely), ``replay``
(``eagc replay``), ``agentcheck`` (``eagc test``).
"""
