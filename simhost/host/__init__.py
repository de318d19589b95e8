"""What organizers run: the sim host that serves one episode over Zenoh (``SimHost``), the
episode interface a world implements (``TrackEpisode``), the MCAP recorder of an episode and
the typed reader of its records. Needs the ``sim`` extra (MuJoCo, mcap)."""
