"""A public name that moved warns instead of failing (issue 31 §5, ``CHANGELOG.md``).

Every old path of ``simhost.MOVED`` imports, under warnings as errors, as a
``DeprecationWarning`` naming the new path; without, as the very module of its new path.
"""

from __future__ import annotations

import importlib
import sys
import warnings

import pytest

import simhost

PUBLIC = ("simhost.agent", "simhost.skills", "simhost.track1", "simhost.track2",
          "simhost.sanity", "simhost.assets")


def _forget(old: str) -> None:
    """Drops the alias (not the module it names), so that the next import finds it anew."""
    for name in [n for n in sys.modules if n == old or n.startswith(old + ".")]:
        del sys.modules[name]


def test_the_public_moves_are_listed() -> None:
    assert set(PUBLIC) <= set(simhost.MOVED)


@pytest.mark.parametrize("old", sorted(simhost.MOVED))
def test_an_old_path_warns_then_is_the_new_module(old: str) -> None:
    new = simhost.MOVED[old]
    _forget(old)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        with pytest.raises(DeprecationWarning, match=f"{old} moved to {new}"):
            importlib.import_module(old)
    _forget(old)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", DeprecationWarning)
        module = importlib.import_module(old)
    assert module is importlib.import_module(new)
    assert [str(w.message) for w in caught if w.category is DeprecationWarning] == [
        f"{old} moved to {new}; import it from there (the old path goes in eagc 0.3, "
        f"CHANGELOG.md)"]


def test_names_import_from_an_old_path() -> None:
    _forget("simhost.agent")
    _forget("simhost.skills")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        from simhost.agent import RemoteEnv
        from simhost.skills import Skills
    from simhost.client import RemoteEnv as NewRemoteEnv
    from simhost.client.skills import Skills as NewSkills

    assert RemoteEnv is NewRemoteEnv and Skills is NewSkills
