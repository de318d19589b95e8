"""The example images' build order and chaining (``orchestrator/_images/build.py``), on a
recording stand-in for the Docker client: a parent image is built before the images built
``FROM`` it, at any depth, and a library image is built but is not an agent."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import docker
import pytest

from orchestrator._images import build
from orchestrator._images.build import (
    HASH_LABEL,
    build_folder,
    example_agents,
    example_images,
)

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
TRACK1_ON_LIBRARY = ("heuristic", "lookahead", "structured", "memoryfree")


class _Image:
    def __init__(self, labels: dict[str, str]) -> None:
        self.labels = labels
        self.id = f"sha256:{abs(hash(tuple(labels.items()))):x}"


class _Images:
    """``client.images``: ``get`` and ``build``, recording what was built in order."""

    def __init__(self) -> None:
        self.tags: dict[str, _Image] = {}
        self.built: list[str] = []

    def get(self, tag: str) -> _Image:
        if tag not in self.tags:
            raise docker.errors.ImageNotFound(tag)
        return self.tags[tag]

    def build(self, *, path: str, tag: str, labels: dict[str, str], **_: Any
              ) -> tuple[_Image, list[Any]]:
        parent = build._parent(Path(path))
        assert parent in self.tags, f"{tag} built before its parent {parent}"
        self.tags[tag] = _Image(labels)
        self.built.append(tag)
        return self.tags[tag], []


class _Client:
    def __init__(self) -> None:
        self.images = _Images()
        self.images.tags[build.AGENT_BASE_IMAGE] = _Image({HASH_LABEL: "base"})


def test_a_parent_image_comes_before_the_images_built_from_it() -> None:
    order = list(example_images())
    for tag, folder in example_images().items():
        parent = build._parent(folder)
        if parent in example_images():
            assert order.index(parent) < order.index(tag), (parent, tag)
    for name in TRACK1_ON_LIBRARY:
        assert build._parent(EXAMPLES / f"track1_{name}") == "eagc/track1-common:latest"
    assert build._parent(EXAMPLES / "track2_taskmodel") == "eagc/track2-demoparser:latest"


def test_the_library_image_is_built_but_is_not_an_agent() -> None:
    assert "eagc/track1-common:latest" in example_images()
    assert "eagc/track1-common:latest" not in example_agents()
    assert all((folder / "agent.py").is_file() for folder in example_agents().values())
    assert set(example_images()) - set(example_agents()) == {"eagc/track1-common:latest"}


@pytest.mark.parametrize(("folder", "tag", "parent"), [
    ("track1_structured", "eagc/track1-structured:latest", "eagc/track1-common:latest"),
    ("track2_taskmodel", "eagc/track2-taskmodel:latest", "eagc/track2-demoparser:latest"),
])
def test_building_a_folder_builds_its_missing_parent_first(folder: str, tag: str,
                                                           parent: str) -> None:
    """``eagc demo`` builds only the images its campaign names: a baseline's parent must be
    built with it, and a rebuilt parent rebuilds it."""
    client = _Client()
    build_folder(client, EXAMPLES / folder, tag, say=lambda m: None)
    assert client.images.built == [parent, tag]
    build_folder(client, EXAMPLES / folder, tag, say=lambda m: None)
    assert client.images.built == [parent, tag], "an unchanged image is reused"
    client.images.tags[build.AGENT_BASE_IMAGE] = _Image({HASH_LABEL: "another base"})
    build_folder(client, EXAMPLES / folder, tag, say=lambda m: None)
    assert client.images.built == [parent, tag, parent, tag]
    build_folder(client, EXAMPLES / folder, tag, say=lambda m: None, force=True)
    assert client.images.built == [parent, tag, parent, tag, tag], (
        "force rebuilds the folder named, not its up-to-date parent")
