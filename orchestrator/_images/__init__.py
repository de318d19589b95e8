"""Images built offline: the base images, the example agents, and the eagc wheel.

``build`` (``eagc images build``), ``wheel`` (the wheel, without a build backend).
"""
