"""One error root per package, every error documented as "Raised when …".

Every exception class defined anywhere in the four packages must derive from its
package's root, and all roots from ``schemas.EagcError``, which the CLI turns into one
line. A new error class that forgets its root fails here.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import pytest

from orchestrator import OrchestratorError
from plugins import PluginError
from schemas import EagcError, SchemaError
from simhost import SimHostError

ROOTS: dict[str, type[Exception]] = {
    "schemas": SchemaError,
    "simhost": SimHostError,
    "plugins": PluginError,
    "orchestrator": OrchestratorError,
}
#: Modules that run something when imported (entry points of a container or a process).
SKIP = {"schemas.__main__", "orchestrator.cli.__main__", "orchestrator._programs.runtime_probe"}


def _errors(package: str) -> list[type[BaseException]]:
    pkg = importlib.import_module(package)
    found: list[type[BaseException]] = []
    for info in pkgutil.walk_packages(pkg.__path__, prefix=f"{package}."):
        if info.name in SKIP:
            continue
        module = importlib.import_module(info.name)
        for _, obj in inspect.getmembers(module, inspect.isclass):
            if issubclass(obj, BaseException) and obj.__module__ == info.name:
                found.append(obj)
    return found


@pytest.mark.parametrize("package", sorted(ROOTS))
def test_every_error_derives_from_its_package_root(package: str) -> None:
    errors = _errors(package)
    assert errors, f"no error classes found in {package}"
    stray = [f"{e.__module__}.{e.__qualname__}" for e in errors
             if not issubclass(e, ROOTS[package]) and e is not EagcError]
    assert not stray, f"not under {ROOTS[package].__name__}: {stray}"
    assert issubclass(ROOTS[package], EagcError)


@pytest.mark.parametrize("package", sorted(ROOTS))
def test_every_error_says_when_it_is_raised(package: str) -> None:
    undocumented = [f"{e.__module__}.{e.__qualname__}: {(e.__doc__ or '').strip()[:60]!r}"
                    for e in _errors(package)
                    if not (e.__doc__ or "").strip().startswith("Raised when")]
    assert not undocumented, undocumented
