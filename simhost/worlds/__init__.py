"""The tracks' simulators (``sanity``, ``track1``, ``track2``), each a gymnasium environment
and a ``TrackEpisode`` for the sim host, and the assets their official splits show.

Nothing to import here: each world is its own package, with its own ``__all__``."""

__all__: list[str] = []
