"""Checkpoints of a training run on Orbax, so that a run can resume after an interruption.

A checkpoint is one step directory holding two items: ``state``, any pytree of arrays
(Flax params, optax state, NamedTuples and ``flax.struct`` dataclasses, int32 counters,
PRNG keys, raw ``uint32`` or typed), and ``meta``, a small JSON dict (the resolved
config, the environment-step count, wall time)::

    with Checkpointer(run_dir / "checkpoints") as checkpointer:
        if checkpointer.latest_step() is not None:
            state, meta = checkpointer.restore(state)
        ...
        checkpointer.save(update, state, {"env_steps": env_steps})

Saves are atomic: Orbax (0.12, local filesystems) writes ``<dir>/<step>.orbax-checkpoint-tmp/``
and renames it to ``<dir>/<step>/`` once every file is written (``commit_success.txt``
last), so a save interrupted by a kill or preemption leaves only a temporary directory,
which is never listed or restored, and which the next ``Checkpointer`` on the directory
deletes. Orbax does not fsync its own JSON files or the rename; `Checkpointer.save` fsyncs
the whole step directory and the rename before it returns, so a checkpoint whose `save`
returned survives an OS crash or power loss too (a crash *during* a save may leave that
newest step incomplete; the older steps are untouched).

In a run of several processes (`jax.distributed`) every process makes the same
`Checkpointer` calls: each writes and reads the parts of global arrays that its devices
hold, and process 0 writes the rest; the directory must be one every process sees.

``sc2jax.atomic.write_json_atomic`` gives the same all-or-nothing guarantee to single JSON
files (configs, results).
"""

from __future__ import annotations

import json
import logging
import os
from collections.abc import Mapping
from typing import Any

import jax
import orbax.checkpoint as ocp
from absl import logging as absl_logging

from sc2jax.atomic import fsync
from sc2jax.checks import check_positive_int

_STATE = "state"
_META = "meta"
_ORBAX_DIR = os.path.dirname(os.path.dirname(os.path.abspath(ocp.__file__)))


class _DropOrbaxInfo(logging.Filter):
    """Drops Orbax's records below WARNING (it logs every file it writes at INFO)."""

    def filter(self, record: logging.LogRecord) -> bool:
        return record.levelno >= logging.WARNING or not record.pathname.startswith(_ORBAX_DIR)


def _quiet_orbax_logging() -> None:
    """Installs `_DropOrbaxInfo` on absl's logger once; other libraries' logs are untouched."""
    logger = absl_logging.get_absl_logger()
    if not any(isinstance(f, _DropOrbaxInfo) for f in logger.filters):
        logger.addFilter(_DropOrbaxInfo())


def _check_step(step: Any) -> int:
    if isinstance(step, bool) or not isinstance(step, int) or step < 0:
        raise ValueError(f"step must be a non-negative int, got {step!r}")
    return step


def _default_device() -> jax.sharding.Sharding:
    """This process's first device (in one process, JAX's default device)."""
    return jax.sharding.SingleDeviceSharding(jax.local_devices()[0])


def placed_as_restored(tree: Any) -> Any:
    """`tree` committed to the default device, as `Checkpointer.restore` places a state.

    A fresh state is uncommitted, and jit compiles a function again for arguments placed
    differently: a run that places its fresh state with this compiles the same program
    when it starts as when it resumes (once per process, and one persistent-cache entry).
    """
    return jax.device_put(tree, _default_device())


def _abstract(target: Any) -> Any:
    """The shape and dtype of every leaf of `target`, placed as the leaf is (a jax array,
    or a `jax.ShapeDtypeStruct` with a sharding: e.g. split over a multi-process mesh,
    each process reading its own parts), else on this process's first device."""
    default = _default_device()

    def leaf(path, x):
        if not (hasattr(x, "shape") and hasattr(x, "dtype")):
            raise TypeError(f"restore target leaf {jax.tree_util.keystr(path)} is a "
                            f"{type(x).__name__}; allowed: arrays or jax.ShapeDtypeStruct")
        sharding = getattr(x, "sharding", None)
        return jax.ShapeDtypeStruct(x.shape, x.dtype, sharding=sharding or default)

    return jax.tree_util.tree_map_with_path(leaf, target)


class Checkpointer:
    """Saves and restores `(state, metadata)` checkpoints by step in one directory.

    A thin wrapper of `orbax.checkpoint.CheckpointManager` (synchronous saves, the
    latest `max_to_keep` steps kept). It logs nothing below WARNING from Orbax: it adds
    a filter, once, to absl's logger that drops Orbax's INFO records only.

    Args:
      directory: where the step directories go; created if missing.
      max_to_keep: how many of the latest checkpoints to keep; older ones are deleted
        after each save.

    Raises:
      ValueError: if `max_to_keep` is not a positive int.
    """

    def __init__(self, directory: str | os.PathLike, *, max_to_keep: int = 3):
        check_positive_int("max_to_keep", max_to_keep)
        _quiet_orbax_logging()
        self.directory = os.path.abspath(os.fspath(directory))
        options = ocp.CheckpointManagerOptions(
            create=True,
            preservation_policy=ocp.checkpoint_managers.LatestN(n=max_to_keep),
            cleanup_tmp_directories=True,
            enable_async_checkpointing=False,
        )
        self._manager = ocp.CheckpointManager(
            self.directory, item_names=(_STATE, _META), options=options)

    def save(self, step: int, state: Any, metadata: Mapping[str, Any] | None = None) -> None:
        """Saves `state` and `metadata` as checkpoint `step`, and returns once it is on disk.

        The save is atomic (see the module docstring): if the process is interrupted,
        the directory holds either this whole checkpoint or none of it. On return every
        file of the checkpoint and the rename are fsynced, so a trainer that saves every
        N updates loses at most the updates after its last `save` returned.

        Args:
          step: the checkpoint's number (e.g. the learner update count); must be larger
            than every step already saved.
          state: a pytree of jax or numpy arrays.
          metadata: a JSON-serialisable dict; `{}` if None.

        Raises:
          ValueError: if `step` is negative or not above the latest saved step.
          TypeError: if `metadata` is not JSON-serialisable.
        """
        step = _check_step(step)
        latest = self.latest_step()
        if latest is not None and step <= latest:
            raise ValueError(f"step {step} must be above the latest saved step {latest}; "
                             f"saved steps: {self.all_steps()}")
        metadata = dict(metadata or {})
        try:
            json.dumps(metadata)
        except TypeError as error:
            raise TypeError(f"metadata must be JSON-serialisable: {error}") from error
        self._manager.save(step, args=ocp.args.Composite(
            **{_STATE: ocp.args.StandardSave(state), _META: ocp.args.JsonSave(metadata)}))
        self._manager.wait_until_finished()
        _fsync_tree(os.path.join(self.directory, str(step)))

    def latest_step(self) -> int | None:
        """Returns the largest completed step, or None if there is no checkpoint."""
        return self._manager.latest_step()

    def all_steps(self) -> list[int]:
        """Returns the completed steps, in increasing order."""
        return sorted(self._manager.all_steps())

    def restore(self, target: Any, step: int | None = None) -> tuple[Any, dict[str, Any]]:
        """Restores checkpoint `step` (the latest if None) into the structure of `target`.

        Args:
          target: a pytree of the saved structure whose leaves (arrays or
            `jax.ShapeDtypeStruct`) give each leaf's shape and dtype, e.g. a freshly
            initialised state or `jax.eval_shape` of its initialiser.
          step: which checkpoint; the latest if None.

        Returns:
          `(state, metadata)`: `state` has `target`'s structure, with jax arrays of
          `target`'s shapes, dtypes and placement (`_abstract`); `metadata` is the dict
          given to `save`.

        Raises:
          FileNotFoundError: if the directory holds no checkpoint.
          ValueError: if `step` is given and was not saved (or has been deleted); from
            Orbax, with a tree diff, if `target`'s structure or a leaf's shape differs
            from the checkpoint's (a differing dtype is cast to `target`'s).
          TypeError: if a leaf of `target` has no shape and dtype.
        """
        steps = self.all_steps()
        if not steps:
            raise FileNotFoundError(f"no checkpoint in {self.directory}")
        if step is None:
            step = steps[-1]
        elif step not in steps:
            raise ValueError(f"no checkpoint for step {step!r} in {self.directory}; "
                             f"available steps: {steps}")
        restored = self._manager.restore(step, args=ocp.args.Composite(
            **{_STATE: ocp.args.StandardRestore(_abstract(target)),
               _META: ocp.args.JsonRestore()}))
        return restored[_STATE], dict(restored[_META])

    def close(self) -> None:
        """Waits for pending work and releases Orbax's resources."""
        self._manager.close()

    def __enter__(self) -> Checkpointer:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()


def _fsync_tree(root: str) -> None:
    """Fsyncs every file and directory under `root`, then `root`'s parent."""
    for dirpath, _, filenames in os.walk(root):
        for name in filenames:
            fsync(os.path.join(dirpath, name))
        fsync(dirpath, directory=True)
    fsync(os.path.dirname(root), directory=True)

