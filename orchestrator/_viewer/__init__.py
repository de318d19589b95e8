"""The episode viewer: a campaign's, a folder of episodes' or one episode's results as
static web pages.

``eagc report`` (``orchestrator.cli.report``) writes them: an index (the leaderboard as the
command line prints it, with intervals and rank ranges), a page per team (its episodes,
verdicts, scores and components) and a page per episode (a stage timeline with a scrubber
over the logged camera frames beside the path on the map, the host's and the agent's
events, each ``/output`` snapshot and what changed, the score card, the failure report and
the agent's last lines). A folder of ``eagc run-episode`` results, without a campaign,
gets the team's page of its episodes and a page per episode. The pages are
self-contained and open from disk. A team's view holds nothing of another team and
nothing of the hidden scenario; the organizer's adds it. docs/viewer.md says how to use
it.

- ``episode``: one episode folder read into what its page shows (``read_episode``)
- ``frames``: camera frames from the MCAP log as small thumbnails (RGB as JPEG where
  smaller), within a budget
- ``site``: the pages, from the Jinja2 ``templates/``
"""

from orchestrator._viewer.site import (
    episode_folders,
    write_campaign_site,
    write_episode_site,
    write_runs_site,
)

__all__ = ["episode_folders", "write_campaign_site", "write_episode_site",
           "write_runs_site"]
