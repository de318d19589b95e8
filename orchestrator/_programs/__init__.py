"""Stand-alone programs the orchestrator starts as scripts (standard library only).

``watcher`` (bounds one Docker episode's container), ``ray_sentinel`` (ends an embedded Ray
whose driver was killed), ``runtime_probe`` (the agent of the runtime conformance suite).
None of them imports eagc: each runs by path, with ``python -S`` where it can.
"""
