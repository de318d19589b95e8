"""The submission channel: teams push images to the challenge's registry, submit them by
digest, and watch them pass a pre-flight, queue, run and score (``docs/channel.md``).

``registry`` (the CNCF registry as a child process, its tokens), ``db`` (SQLite: teams,
tokens, submissions, history; the clock), ``channel`` (the rules: states, leases, what a
team is shown), ``api`` (FastAPI), ``client`` (a team's and the runner's HTTP client, the
push), ``runner`` (claims pre-flights and runs, plays them on Ray), ``serve`` (``eagc
challenge serve``: registry, API and runner together).
"""
