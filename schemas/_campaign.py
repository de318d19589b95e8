"""The campaign spec (``campaign.yaml``) and the limits every agent container runs under."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator


class _Spec(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class Limits(_Spec):
    """Resources and time granted to one agent container (docs/contract.md)."""

    cpus: float = Field(default=1.0, gt=0, description="CPU quota in cores.")
    memory_mb: int = Field(default=2048, ge=32, description="Memory limit; swap equals memory.")
    pids: int = Field(default=256, ge=8)
    gpus: tuple[str, ...] = Field(default=(), description="GPU device ids granted, if any.")
    tmp_mb: int = Field(default=256, ge=1, description="Size of the /tmp tmpfs.")
    output_mb: int = Field(default=64, ge=1, description="Size cap of /output.")
    output_file_mb: int = Field(default=32, ge=1, description="Size cap of one collected file.")
    log_mb: int = Field(default=10, ge=1, description="Container log size cap.")
    time_scale: float = Field(
        default=1.0, gt=0, le=1.0, description="Multiplies every stage budget (local tests)."
    )
    max_steps_per_stage: int | None = Field(
        default=None, ge=1, description="Caps steps in each stage, for machine-independent tests."
    )
    startup_s: float = Field(default=120.0, gt=0, description="Time to the agent's reset.")
    pin_cpus: bool = Field(
        default=True,
        description="Run the agent on cores apart from its sim host's where the machine has "
        "enough free cores (one for the host, ceil(cpus) for the agent).",
    )
    max_request_kb: int = Field(default=1024, ge=1)
    max_protocol_errors: int = Field(
        default=1000, ge=1, description="Protocol errors before the episode ends as a violation."
    )


class Split(_Spec):
    name: str = Field(pattern=r"^[a-z0-9_-]+$")
    weight: float = Field(default=1.0, gt=0)
    episodes: int = Field(ge=1)
    params: dict[str, object] = Field(
        default_factory=dict, description="Track-specific scenario parameters of the split."
    )


class Submission(_Spec):
    team: str = Field(pattern=r"^[A-Za-z0-9_.-]+$")
    image: str
    digest: str | None = Field(
        default=None, description="Pinned image ID (sha256:…); checked before the campaign."
    )
    archive: Path | None = Field(default=None, description="A `docker save` archive to load.")
    disclosure: Path | None = Field(
        default=None,
        description="The team's resource disclosure (YAML or JSON, `ResourceDisclosure`; "
        "relative to the campaign file): kept beside the pinned image, shown to organizers.")


class CampaignSpec(_Spec):
    """``campaign.yaml``."""

    name: str = Field(pattern=r"^[A-Za-z0-9_.-]+$")
    track: str
    phase: Literal["local", "testing", "qualification", "hidden_validation", "final"] = "local"
    splits: tuple[Split, ...] = Field(min_length=1)
    submissions: tuple[Submission, ...] = Field(min_length=1)
    limits: Limits = Limits()
    retries: int = Field(default=2, ge=0, description="Retries of an infrastructure failure.")
    output: Path = Path("runs")
    secret: str | None = Field(
        default=None,
        description="Where the seed secret lives: 'env:NAME' or 'file:/path'. None: a local "
        "campaign derives seeds from the campaign name (public, never for official runs).",
    )
    runtime: Literal["docker", "local"] = "docker"

    @field_validator("secret")
    @classmethod
    def _secret_location(cls, v: str | None) -> str | None:
        if v is not None and not (v.startswith("env:") or v.startswith("file:")):
            raise ValueError("secret must be 'env:NAME' or 'file:/path', never the secret itself")
        return v

    @model_validator(mode="after")
    def _unique(self) -> CampaignSpec:
        for what, names in (
            ("split", [s.name for s in self.splits]),
            ("team", [s.team for s in self.submissions]),
        ):
            dupes = {n for n in names if names.count(n) > 1}
            if dupes:
                raise ValueError(f"duplicate {what} names: {sorted(dupes)}")
        if self.phase != "local" and self.secret is None:
            raise ValueError(f"a {self.phase} campaign needs a secret location")
        return self
