"""The container contract: everything a team's container may rely on, in one place.

The sim host, the container runtimes, the runtime conformance suite and the docs all read
it from here (``schemas.CONTAINER``); nothing else spells these paths, names or numbers.
Light on purpose (no imports beyond the standard library): team images import it.
"""

from __future__ import annotations

from dataclasses import dataclass


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
    #: Environment: the Zenoh endpoint to connect to.
    env_endpoint: str = "EAGC_ENDPOINT"
    #: Environment: the opaque episode id (4-64 of ``[A-Za-z0-9_-]``; part of every key).
    env_episode: str = "EAGC_EPISODE"
    #: Environment: where to write files (``output_dir`` in a container).
    env_output: str = "EAGC_OUTPUT"
    #: Environment: where inputs are (``input_dir`` in a container); set only when present.
    env_input: str = "EAGC_INPUT"
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
            "HOME": self.tmp_dir,
            "PYTHONUNBUFFERED": "1",
        }
        if input_dir is not None:
            env[self.env_input] = input_dir
        return env


def unix_endpoint(socket_path: str) -> str:
    """The Zenoh endpoint of a unix socket path: the one place this string is built."""
    return f"unixsock-stream/{socket_path}"


#: The contract in force.
CONTAINER = ContainerContract()
