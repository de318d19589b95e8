"""The container contract: everything a team's container may rely on, in one place.

The sim host, the container runtimes, the runtime conformance suite and the docs all read
it from here (``schemas.CONTAINER``); nothing else spells these paths, names or numbers.
Light on purpose (no imports beyond the standard library): team images import it.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any


def _env(name: str, meaning: str) -> Any:
    """A field naming an environment variable ``name``; ``meaning`` is what the docs (and
    ``ContainerContract.variables``) say of it."""
    return field(default=name, metadata={"meaning": meaning})


@dataclass(frozen=True)
class ContainerContract:
    """Paths, environment names and identity a team's container sees in every episode."""

    #: Folder holding the host's unix socket, mounted read-only in the container.
    socket_dir: str = "/run/eagc"
    #: The socket's file name inside ``socket_dir`` (on the host: ``<episode>/sock/``).
    socket_name: str = "zenoh.sock"
    #: Writable, size-capped folder for the model files and the log.
    output_dir: str = "/output"
    #: Read-only inputs (Track 2's demonstration packet), when the track has any.
    input_dir: str = "/input"
    #: The fixed non-root uid (and gid) the agent runs as.
    uid: int = 10001
    #: Small writable tmpfs; also ``$HOME``.
    tmp_dir: str = "/tmp"
    # The environment a container gets (``environment()``): each field names a variable
    # and says what it means (``variables()``, and the docs' tables generated from it).
    env_endpoint: str = _env(
        "EAGC_ENDPOINT", "the Zenoh endpoint to connect to: a unix socket in `/run/eagc`, "
        "read-only (the container has no network)")
    env_episode: str = _env(
        "EAGC_EPISODE", "the opaque episode id (4-64 of `[A-Za-z0-9_-]`), part of every "
        "key; never a seed, split, campaign or team name")
    env_output: str = _env(
        "EAGC_OUTPUT", "where the files go: writable, size-capped, snapshotted at every "
        "stage end and when the episode ends")
    env_input: str = _env(
        "EAGC_INPUT", "read-only inputs (Track 2's demonstration packet); set only when the "
        "track has inputs")
    env_home: str = _env(
        "HOME", "the home folder: the small writable tmpfs (the root is read-only)")
    env_unbuffered: str = _env(
        "PYTHONUNBUFFERED", "Python writes stdout and stderr unbuffered, so that the log's "
        "last lines are there when the agent dies")
    #: Longest socket path the host accepts: AF_UNIX paths are limited to 108 bytes.
    max_socket_path: int = 100

    @property
    def socket_path(self) -> str:
        """The socket as the container sees it."""
        return f"{self.socket_dir}/{self.socket_name}"

    def environment(
        self, episode: str, *, socket_dir: str, output_dir: str, input_dir: str | None
    ) -> dict[str, str]:
        """The agent's whole environment: endpoint, opaque episode id, its folders. Nothing
        else (no seed, split, campaign or team ever enters it).

        The folders are as the agent sees them: the contract's own paths in a container,
        host paths for a local process.
        """
        env = {
            self.env_endpoint: unix_endpoint(f"{socket_dir}/{self.socket_name}"),
            self.env_episode: episode,
            self.env_output: output_dir,
            self.env_home: self.tmp_dir,
            self.env_unbuffered: "1",
        }
        if input_dir is not None:
            env[self.env_input] = input_dir
        return env


    def variables(self) -> tuple[EnvVariable, ...]:
        """Every environment variable of the contract, with the value a container sees
        (``<episode>`` for the episode id) and what it means: ``environment()`` sets these
        and nothing else."""
        seen = self.environment("<episode>", socket_dir=self.socket_dir,
                                output_dir=self.output_dir, input_dir=self.input_dir)
        out = []
        for f in fields(self):
            if "meaning" in f.metadata:
                name = getattr(self, f.name)
                out.append(EnvVariable(name, seen[name], f.metadata["meaning"],
                                       always=f.name != "env_input"))
        assert {v.name for v in out} == set(seen), "environment() and the fields disagree"
        return tuple(out)


@dataclass(frozen=True)
class EnvVariable:
    """One environment variable of the contract: its name, the value a container sees,
    what it means, and whether every episode sets it."""

    name: str
    value: str
    meaning: str
    always: bool = True


def unix_endpoint(socket_path: str) -> str:
    """The Zenoh endpoint of a unix socket path: the one place this string is built."""
    return f"unixsock-stream/{socket_path}"


#: The contract in force.
CONTAINER = ContainerContract()
