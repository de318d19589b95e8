"""The sanity track (entry point ``sanity``): fast end-to-end checks with the real shape."""

from plugins.sanity._track import SanityEpisode, SanityTrack

__all__ = ["SanityEpisode", "SanityTrack"]
