"""Campaigns: the spec and plan, hidden seeds, the Ray fan-out, the driver, metrics.

``spec`` (the YAML spec, the plan, pinned images), ``seeds`` (hidden seeds, commitment),
``fanout`` (one Ray task per episode), ``driver`` (``run_campaign``), ``metrics``
(Prometheus), ``rebuild`` (``rebuild-store``).
"""
