"""Plain space descriptions: what ``GymEnv`` offers where gymnasium is not installed.

Three frozen classes with the parts of ``gymnasium.spaces.Box``, ``Discrete`` and ``Dict``
that a policy reads (``shape``, ``dtype``, ``low``, ``high``, ``n``, ``start``, ``spaces``,
``contains``, ``seed``, ``sample``), so that code written against gymnasium's spaces runs on
the light install (numpy only). ``sample()`` draws from a generator seeded by ``seed()``
(seed 0 until then: nothing random without a seed).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["PlainBox", "PlainDict", "PlainDiscrete", "PlainSpace"]


@dataclass(frozen=True, eq=False)
class _Seeded:
    _rng: list[np.random.Generator] = field(
        default_factory=lambda: [np.random.default_rng(0)], init=False, repr=False)

    def seed(self, seed: int | None = None) -> list[int]:
        """Seeds ``sample()`` (None: seed 0). Returns the seed, as gymnasium does."""
        value = 0 if seed is None else int(seed)
        self._rng[0] = np.random.default_rng(value)
        return [value]

    @property
    def np_random(self) -> np.random.Generator:
        return self._rng[0]


@dataclass(frozen=True, eq=False)
class PlainBox(_Seeded):
    """An array of ``shape`` and ``dtype`` with inclusive bounds (as ``gymnasium.spaces.Box``).

    Args:
        low: Lower bounds, broadcast to ``shape``.
        high: Upper bounds, broadcast to ``shape``.
        shape: The array's shape (``()`` for a scalar).
        dtype: The array's numpy dtype.
    """

    low: np.ndarray
    high: np.ndarray
    shape: tuple[int, ...]
    dtype: np.dtype[Any]

    def contains(self, x: Any) -> bool:
        """True when ``x`` has the shape, a dtype that casts safely, and is within bounds."""
        arr = np.asarray(x)
        if arr.shape != self.shape or not np.can_cast(arr.dtype, self.dtype):
            return False
        return bool(np.all(arr >= self.low) and np.all(arr <= self.high))

    def sample(self) -> np.ndarray:
        """A uniform draw within the bounds (floats: infinite bounds clipped to ±1e6)."""
        rng = self.np_random
        if self.dtype.kind == "b":
            return rng.integers(0, 2, self.shape).astype(self.dtype)
        if self.dtype.kind in "iu":
            return rng.integers(self.low, self.high, self.shape, endpoint=True,
                                dtype=np.int64).astype(self.dtype)
        low, high = np.maximum(self.low, -1e6), np.minimum(self.high, 1e6)
        return rng.uniform(low, high, self.shape).astype(self.dtype)

    def __contains__(self, x: Any) -> bool:
        return self.contains(x)

    def __repr__(self) -> str:
        lo, hi = np.min(self.low), np.max(self.high)
        return f"PlainBox({lo}, {hi}, {self.shape}, {self.dtype})"


@dataclass(frozen=True, eq=False)
class PlainDiscrete(_Seeded):
    """One of ``n`` integers ``start`` … ``start + n - 1`` (as ``gymnasium.spaces.Discrete``)."""

    n: int
    start: int = 0
    shape: tuple[int, ...] = ()
    dtype: np.dtype[Any] = np.dtype(np.int64)

    def contains(self, x: Any) -> bool:
        """True for an integer (Python or numpy scalar) in range."""
        arr = np.asarray(x)
        if arr.shape != () or arr.dtype.kind not in "iu":
            return False
        return self.start <= int(arr) < self.start + self.n

    def sample(self) -> np.int64:
        """A uniform draw."""
        return np.int64(self.start + self.np_random.integers(self.n))

    def __contains__(self, x: Any) -> bool:
        return self.contains(x)

    def __repr__(self) -> str:
        return f"PlainDiscrete({self.n}{'' if not self.start else f', start={self.start}'})"


@dataclass(frozen=True, eq=False)
class PlainDict(_Seeded):
    """Named spaces (as ``gymnasium.spaces.Dict``): ``space["move"]``, ``space.spaces``."""

    spaces: Mapping[str, PlainBox | PlainDiscrete | PlainDict]

    def __getitem__(self, key: str) -> PlainBox | PlainDiscrete | PlainDict:
        return self.spaces[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self.spaces)

    def __len__(self) -> int:
        return len(self.spaces)

    def keys(self) -> Any:
        return self.spaces.keys()

    def items(self) -> Any:
        return self.spaces.items()

    def seed(self, seed: int | None = None) -> list[int]:
        """Seeds every member, each from its own draw of ``seed``."""
        out = super().seed(seed)
        for i, space in enumerate(self.spaces.values()):
            space.seed(out[0] * 1_000_003 + i)
        return out

    def contains(self, x: Any) -> bool:
        """True for a mapping with exactly these keys, each value in its space."""
        if not isinstance(x, Mapping) or set(x) != set(self.spaces):
            return False
        return all(space.contains(x[k]) for k, space in self.spaces.items())

    def sample(self) -> dict[str, Any]:
        """A draw of every member."""
        return {k: space.sample() for k, space in self.spaces.items()}

    def __contains__(self, x: Any) -> bool:
        return self.contains(x)

    def __repr__(self) -> str:
        return "PlainDict(" + ", ".join(f"{k!r}: {v!r}" for k, v in self.spaces.items()) + ")"


PlainSpace = PlainBox | PlainDiscrete | PlainDict
"""Any of the three."""
