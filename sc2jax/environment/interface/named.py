"""Observations read by name, as PySC2's are: `NamedNumpyArray` and `NamedDict`.

    obs["feature_screen"].player_relative          # the layer, whichever layers exist
    obs["feature_screen"]["player_relative"]       # the same
    obs.player.minerals                            # NamedDict attribute, named column
    [u for u in obs.feature_units if u.alliance == PlayerRelative.SELF]

A `NamedNumpyArray` is an `np.ndarray` whose dimensions may each name their indices. An
index by name (a str, or an attribute) is the index of that name in the first dimension
that has it. Slicing keeps the names of the dimensions it keeps (a slice or a list of
indices renames them to the entries kept); an int drops its dimension; anything else
(boolean masks, several index arrays, reshapes, reductions) gives an array without
names. Arithmetic keeps the names where the shape is unchanged.
"""

from __future__ import annotations

import enum
import numbers
from collections.abc import Sequence

import jax
import numpy as np

Names = Sequence[str] | type[enum.IntEnum] | None


def _as_names(names: Names, length: int) -> tuple[str, ...] | None:
    if names is None:
        return None
    if isinstance(names, type) and issubclass(names, enum.IntEnum):
        if sorted(m.value for m in names) != list(range(len(names))):
            raise ValueError(f"{names.__name__}'s values are not 0..{len(names) - 1}")
        names = [m.name for m in sorted(names, key=lambda m: m.value)]
    names = tuple(names)
    if len(names) != length:
        raise ValueError(f"{len(names)} names for a dimension of {length}: {names}")
    if len(set(names)) != len(names) or not all(isinstance(n, str) for n in names):
        raise ValueError(f"names must be distinct strings, got {names}")
    return names


class NamedNumpyArray(np.ndarray):
    """An ndarray with names for the indices of some of its dimensions.

    Args:
      values: the array (not copied where it is one already).
      names: one entry per leading dimension: None (no names), a sequence of names as
        long as the dimension, or an IntEnum with values 0..n-1. Later dimensions have
        none.

    Raises:
      ValueError: more entries than dimensions, or names that do not fit their dimension.
    """

    def __new__(cls, values, names: Sequence[Names]):
        array = np.asarray(values).view(cls)
        names = list(names)
        if len(names) > array.ndim:
            raise ValueError(f"{len(names)} name entries for an array of {array.ndim} "
                             f"dimensions (shape {array.shape})")
        names += [None] * (array.ndim - len(names))
        array._index_names = tuple(_as_names(n, size) for n, size in zip(names, array.shape))
        return array

    def __array_finalize__(self, source) -> None:
        names = getattr(source, "_index_names", None)
        same = names is not None and getattr(source, "shape", None) == self.shape
        self._index_names = names if same else (None,) * self.ndim

    def __array_wrap__(self, array, context=None, return_scalar=False):
        result = super().__array_wrap__(array, context, return_scalar)
        if isinstance(result, np.ndarray) and result.ndim == 0:
            return np.ndarray.__getitem__(result, ())  # A reduction's scalar, as numpy's.
        return result

    def __reduce__(self):
        reconstruct, args, state = super().__reduce__()
        return reconstruct, args, (state, self._index_names)

    def __setstate__(self, state) -> None:
        array_state, self._index_names = state
        super().__setstate__(array_state)

    @property
    def index_names(self) -> tuple[tuple[str, ...] | None, ...]:
        """Each dimension's names (None where it has none)."""
        return self._index_names

    def __getattr__(self, name: str):
        if name.startswith("__") or name == "_index_names":
            raise AttributeError(name)
        for dim, names in enumerate(self._index_names):
            if names is not None and name in names:
                return self[(slice(None),) * dim + (names.index(name),)]
        raise AttributeError(f"{type(self).__name__} has no attribute or index name "
                             f"{name!r}; its names: {self._described()}")

    def __dir__(self):
        names = [n for names in self._index_names if names for n in names]
        return sorted(set(super().__dir__()) | set(names))

    def __getitem__(self, index):
        key, names = self._resolve(index)
        result = super().__getitem__(key)
        if isinstance(result, NamedNumpyArray):
            result._index_names = (tuple(names) if names is not None
                                   and len(names) == result.ndim else (None,) * result.ndim)
        return result

    def __setitem__(self, index, value) -> None:
        super().__setitem__(self._resolve(index)[0], value)

    # Internals.

    def _described(self) -> str:
        return "; ".join(f"dimension {d}: {', '.join(n)}" for d, n in
                         enumerate(self._index_names) if n) or "none"

    def _lookup(self, dim: int, name: str) -> int:
        names = self._index_names[dim] if dim < self.ndim else None
        if names is None or name not in names:
            raise KeyError(f"no index named {name!r} in dimension {dim} of an array of "
                           f"shape {self.shape}; its names: {self._described()}")
        return names.index(name)

    def _resolve(self, index):
        """(the numpy index, the result's names or None when they cannot be followed)."""
        items = list(index) if isinstance(index, tuple) else [index]
        used = sum(1 for k in items if k is not None and k is not Ellipsis)
        dim, key, names, arrays = 0, [], [], 0
        for item in items:
            if item is Ellipsis:
                for _ in range(self.ndim - used):
                    names.append(self._index_names[dim])
                    dim += 1
                key.append(Ellipsis)
                continue
            if item is None:
                key.append(None)
                names.append(None)
                continue
            current = self._index_names[dim] if dim < self.ndim else None
            if isinstance(item, str):
                item = self._lookup(dim, item)
            elif _is_str_list(item):
                item = [self._lookup(dim, n) for n in item]
            if isinstance(item, numbers.Integral):
                key.append(item)
            elif isinstance(item, slice):
                key.append(item)
                names.append(None if current is None else current[item])
            else:
                positions = np.asarray(item)
                arrays += 1
                if positions.dtype.kind in "iu" and positions.ndim == 1 and current:
                    names.append(tuple(current[i] for i in positions))
                else:
                    names.append(None)
                    dim += max(positions.ndim - 1, 0) if positions.dtype == bool else 0
                key.append(item)
            dim += 1
        names.extend(self._index_names[dim:])
        return tuple(key), (names if arrays <= 1 else None)


def _is_str_list(item) -> bool:
    return (isinstance(item, (list, tuple)) and len(item) > 0
            and all(isinstance(n, str) for n in item))


class NamedDict(dict):
    """A dict whose keys are also attributes (`obs.feature_screen`)."""

    def __getattr__(self, name: str):
        try:
            return self[name]
        except KeyError:
            raise AttributeError(f"no observation {name!r}; it has {sorted(self)}") from None

    def __dir__(self):
        return sorted(set(super().__dir__()) | set(self))


jax.tree_util.register_pytree_with_keys(  # As a dict: `jax.tree.map` sees its arrays.
    NamedDict,
    lambda d: ([(jax.tree_util.DictKey(k), d[k]) for k in sorted(d)], tuple(sorted(d))),
    lambda keys, values: NamedDict(zip(keys, values)))
