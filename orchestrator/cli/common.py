"""What every ``eagc`` command shares: exit codes, one-line errors, checked arguments.

Exit codes (``eagc --help`` and docs/commands.md show the same table)::

    0    success (run-episode: the episode completed)
    1    an error, printed on one line (a file that does not validate, no Docker engine,
         an image that does not build, …), or a check that does not hold (replay --verify,
         campaign reveal)
    2    usage error: an unknown command or option, or a value eagc cannot use (a track or
         split that does not exist, a negative seed, a folder that is not an episode)
    3    infrastructure failure, not the agent's fault (run-episode; campaign run: episodes
         quarantined after their retries)
    4    the agent failed (run-episode: crash, timeout, OOM, protocol, bad files, no start;
         test: the container does not meet the contract)
    5    campaign run: the results store failed (a full disk) or was refused (damaged, or
         empty beside existing results: eagc campaign rebuild-store)
    6    campaign run: the Ray cluster was lost
    130  cancelled (Ctrl-C)

Any ``schemas.EagcError`` a command lets through (every package's errors derive from it)
is printed as ``error: <first line of the message>`` on stderr, never as a traceback. An
unexpected exception is a bug: one line too, with the traceback written to a file that the
line names (``EAGC_DEBUG=1`` shows it instead).
"""

from __future__ import annotations

import difflib
import os
import sys
import tempfile
import traceback
from enum import IntEnum
from pathlib import Path
from typing import Any

import typer
from typer.core import TyperGroup

from orchestrator._errors import UsageError
from schemas import EagcError, SchemaError


class ExitCode(IntEnum):
    """The exit codes of every ``eagc`` command (module docstring)."""

    OK = 0
    ERROR = 1
    USAGE = 2
    INFRA = 3
    AGENT = 4
    STORE = 5
    CLUSTER = 6
    CANCELLED = 130


EXIT_CODES_HELP = (
    "Exit codes: 0 success (run-episode: the episode completed); 1 an error, on one line, "
    "or a check that does not hold; 2 usage error (unknown track or split, bad value); "
    "3 infrastructure failure (campaign run: episodes quarantined); 4 the agent failed "
    "(test: the container does not meet the contract); 5 the results store failed or was "
    "refused; 6 the Ray cluster was lost (campaign run); 130 cancelled."
)


def error_line(e: BaseException) -> str:
    """The one line a user sees for an eagc error: the first line of its message."""
    if isinstance(e, SchemaError):
        return e.summary
    text = str(e).strip()
    return text.splitlines()[0] if text else type(e).__name__


def _bug_line(e: BaseException) -> str:
    """One line for an unexpected exception; its traceback goes to a file."""
    fd, path = tempfile.mkstemp(prefix="eagc-traceback-", suffix=".txt")
    with os.fdopen(fd, "w") as f:
        f.write("".join(traceback.format_exception(e)))
    return (f"unexpected {type(e).__name__}: {error_line(e)} (a bug in eagc: the traceback "
            f"is in {path}; EAGC_DEBUG=1 shows it)")


def say_error(message: str) -> None:
    """Prints ``error: message`` on stderr as one line (never wrapped by eagc)."""
    print(f"error: {message}", file=sys.stderr, flush=True)


#: Exits commands ask for, and the usage errors of the click that typer runs on.
_EXITS = (typer.Exit, typer.Abort)
_CLICK_ERRORS = tuple(c for c in typer.BadParameter.__mro__ if c.__name__ == "ClickException")


class OneLineErrors(TyperGroup):
    """A command group whose commands end in one line, never a traceback (module doc)."""

    def invoke(self, ctx: Any) -> Any:
        try:
            return super().invoke(ctx)
        except _EXITS:
            raise
        except _CLICK_ERRORS as e:  # a bad option or value, an unknown command
            if type(e).__name__ == "NoArgsIsHelpError":
                raise  # `eagc campaign` alone: its help
            where = getattr(e, "ctx", None)
            hint = f" (see `{where.command_path} --help`)" if where is not None else ""
            say_error(e.format_message() + hint)
            raise typer.Exit(e.exit_code) from None
        except KeyboardInterrupt:
            say_error("cancelled")
            raise typer.Exit(ExitCode.CANCELLED) from None
        except UsageError as e:
            say_error(error_line(e))
            raise typer.Exit(ExitCode.USAGE) from None
        except EagcError as e:
            say_error(error_line(e))
            raise typer.Exit(ExitCode.ERROR) from None
        except OSError as e:  # a folder that cannot be written, a disk that is full, …
            say_error(f"{e.strerror or e}" + (f": {e.filename}" if e.filename else ""))
            raise typer.Exit(ExitCode.ERROR) from None
        except Exception as e:  # noqa: BLE001 - a bug: still one line, the traceback kept
            if os.environ.get("EAGC_DEBUG"):
                raise
            say_error(_bug_line(e))
            raise typer.Exit(ExitCode.ERROR) from None


# ---------------------------------------------------------------------------- arguments
def _suggest(name: str, choices: list[str]) -> str:
    hint = difflib.get_close_matches(name, choices, n=1, cutoff=0.5)
    return f" Did you mean {hint[0]!r}?" if hint else ""


def check_track(name: str) -> Any:
    """The installed track ``name`` (a ``TrackPlugin``); UsageError with a suggestion if
    there is none of that name."""
    from plugins import available_tracks, load_track

    names = available_tracks()
    if name not in names:
        raise UsageError(f"no track named {name!r}.{_suggest(name, names)} Installed "
                         f"tracks: {', '.join(names) or 'none'}")
    return load_track(name)


def check_split(plugin: Any, split: str) -> str:
    """``split`` if ``plugin`` has it (``TrackPlugin.split_names()``); UsageError with a
    suggestion otherwise."""
    names = list(plugin.split_names())
    if split not in names:
        raise UsageError(f"track {plugin.name!r} has no split {split!r}."
                         f"{_suggest(split, names)} Its splits: {', '.join(names)}")
    return split


#: What ``--seed`` accepts: seeds are non-negative (campaigns derive 63-bit ones).
SEED_RANGE = {"min": 0}


def episode_folder(path: Path) -> Path:
    """An episode folder (``<runs>/<episode>`` with ``host/result.json``); UsageError naming
    what is missing otherwise."""
    if not path.exists():
        raise UsageError(f"{path} does not exist")
    if not path.is_dir():
        raise UsageError(f"{path} is not a folder: give an episode folder (runs/<episode>)")
    if not (path / "host" / "result.json").is_file():
        raise UsageError(f"{path} is not an episode folder: it has no host/result.json "
                         "(episode folders are runs/<episode>, as run-episode prints)")
    return path


MCAP_MAGIC = b"\x89MCAP0\r\n"


def episode_log(path: Path) -> Path:
    """The MCAP log of an episode folder, or ``path`` itself if it is one; UsageError
    naming what is wrong otherwise."""
    if path.is_dir():
        log = path / "host" / "episode.mcap"
        if not log.is_file():
            raise UsageError(f"{path} is not an episode folder: it has no host/episode.mcap")
        path = log
    elif not path.exists():
        raise UsageError(f"{path} does not exist")
    with path.open("rb") as f:
        if f.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
            raise UsageError(f"{path} is not an MCAP episode log")
    return path


STARTUP_FLOOR_S = 60.0
"""The least startup budget a time scale leaves: time for a real container to start and
load its models (a campaign grants the full 120 s)."""


def scaled_startup_s(time_scale: float) -> float:
    """The startup budget under ``--time-scale``: the default one scaled, never below
    STARTUP_FLOOR_S."""
    from schemas import Limits

    default = Limits().startup_s
    return max(STARTUP_FLOOR_S, min(default, default * time_scale))


def limits_of(*, time_scale: float = 1.0, **values: Any) -> Any:
    """``schemas.Limits`` from command-line values; UsageError naming the option otherwise.
    A time scale in (0, 1] scales the startup budget too (scaled_startup_s)."""
    from pydantic import ValidationError

    from schemas import Limits, describe

    if 0 < time_scale <= 1:
        values.setdefault("startup_s", scaled_startup_s(time_scale))
    try:
        return Limits(time_scale=time_scale, **values)
    except ValidationError as e:
        options = {"max_steps_per_stage": "max-steps"}
        first = describe(e)[0]
        key, _, what = first.partition(": ")
        raise UsageError(f"--{options.get(key, key.replace('_', '-'))}: {what}") from None


def _left(total_s: float) -> str:
    return f"{max(0, int(total_s + 0.999))} s left"


def wait_text(elapsed_s: float, limits: Any, stage: Any = None, stage_s: float = 0.0) -> str:
    """What an episode's spinner says ``elapsed_s`` in: the wait for the agent's hello and
    the startup budget left, then (``stage``, a StageSpec begun ``stage_s`` ago) the stage
    and the time left of its budget."""
    if stage is None:
        if elapsed_s < limits.startup_s:
            return f"waiting for the agent's hello ({_left(limits.startup_s - elapsed_s)})"
        return "the startup budget is up"
    return f"stage {stage.name}, {_left(stage.budget_s * limits.time_scale - stage_s)}"


class episode_spinner:  # noqa: N801 - used as a context manager, like a function
    """``notes.status`` whose text says, each second, what the episode waits for and the
    time left: it follows the stages through the track's episode (``plugin`` is the cached
    instance that the worker loads too)."""

    def __init__(self, status_of: Any, label: str, limits: Any, plugin: Any) -> None:
        self._status_of, self._label, self._limits, self._plugin = (
            status_of, label, limits, plugin)
        self._stages = {s.name: s for s in plugin.stages()}
        self._stage: Any = None
        self._stage_at = 0.0

    def text(self, elapsed_s: float, now: float | None = None) -> str:
        import time

        stage_s = (now if now is not None else time.monotonic()) - self._stage_at
        what = wait_text(elapsed_s, self._limits, self._stage, stage_s)
        return f"{self._label}: {what}"

    def _follow(self) -> None:
        import time

        make = type(self._plugin).make_episode
        spinner = self

        def make_episode(scenario: Any) -> Any:
            episode = make(spinner._plugin, scenario)
            started = episode.on_stage_start

            def on_stage_start(stage: str) -> Any:
                spinner._stage, spinner._stage_at = spinner._stages.get(stage), time.monotonic()
                return started(stage)

            episode.on_stage_start = on_stage_start
            return episode

        self._plugin.make_episode = make_episode

    def __enter__(self) -> episode_spinner:
        import threading
        import time

        self._follow()
        self._cm = self._status_of(self.text(0.0))
        status = self._cm.__enter__()
        self._stop = threading.Event()
        start = time.monotonic()

        def tick() -> None:
            while not self._stop.wait(1.0):
                if status is not None:
                    status.update(self.text(time.monotonic() - start))

        self._thread = threading.Thread(target=tick, daemon=True, name="eagc-spinner")
        self._thread.start()
        return self

    def __exit__(self, *exc: Any) -> Any:
        self._stop.set()
        self._thread.join(2.0)
        self._plugin.__dict__.pop("make_episode", None)
        return self._cm.__exit__(*exc)
