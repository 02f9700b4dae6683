"""The compiled training loop on the simulator: environments, acting and learning.

One training step unrolls the actor for K steps with the current parameters and
applies one learner update to that trajectory (synchronous A2C: the paper's A3C
without the asynchrony), all in one compiled program. A chunk is `updates_per_chunk`
such steps; the host only logs and checkpoints between chunks. A sweep trains R runs
of one config together.

A pipelined chunk (`pipelined=True`) acts for the next batch while it learns from the
last: the two do not depend on each other, so XLA may run them at once (on CPU its
runtime runs independent operations concurrently). Within a chunk of U updates, batch 1
is acted with the chunk's first parameters, then U - 1 programs each act for batch u + 1
and learn from batch u, and a last update learns from batch U: every batch but the first
two of a chunk is acted with the parameters one update behind those that learn from it
(V-trace or PPO correct for that; A3C ignores it). Nothing crosses a chunk's end, so the
state, checkpoints and resumption are those of the plain chunk.

On accelerators the chunk's steps run inside `lax.scan`, so a chunk is one program,
and a sweep vmaps the step over its runs. On XLA's CPU backend a convolution's
gradient inside a loop runs about 8x slower than the same program outside one
(docs/benchmarks.md), so there the chunk calls the compiled step once per update from
Python; the step itself is still one program. A sweep there calls one run's step for
each run in turn, since the vmapped step's run-grouped convolutions ran 1.6-1.9x slower
per run (FullyConv at 16², 4 environments x K = 16, 2 runs: 0.34-0.39 s against
0.21 s per update and run, the 2-core machine).
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import jax
import jax.numpy as jnp
from flax import struct

from sc2jax.checks import check_positive_int
from sc2jax.experiments.training.actor import ActorState, EpisodeLog, Unroll
from sc2jax.experiments.training.learner import Learner, LearnerState


class TrainState(struct.PyTreeNode):
    """Everything a run needs to continue: the learner's and the actor's state."""

    learner: LearnerState
    actor: ActorState


ChunkFn = Callable[[TrainState], tuple[TrainState, dict[str, jax.Array], EpisodeLog]]


def make_train_step(unroll: Unroll, learner: Learner):
    """`step(state) -> (state, metrics, episodes)`: one unroll and one update (pure).

    Metrics are float32 scalars; `episodes` is the unroll's `EpisodeLog`, leaves [K, B].
    """

    def train_step(state: TrainState):
        actor, trajectory, episodes = unroll.unroll(state.learner.params, state.actor)
        learner_state, metrics = _learn(learner, state.learner, trajectory)
        return TrainState(learner_state, actor), metrics, episodes

    return train_step


def _learn(learner: Learner, learner_state: LearnerState, trajectory):
    """One update, its metrics as float32 scalars."""
    learner_state, metrics = learner.update(learner_state, trajectory)
    return learner_state, jax.tree.map(lambda m: jnp.asarray(m, jnp.float32), metrics)


def make_train_chunk(unroll: Unroll, learner: Learner, updates_per_chunk: int, *,
                     num_runs: int | None = None, scan: bool | None = None,
                     pipelined: bool = False) -> ChunkFn:
    """A compiled `chunk(state) -> (state, metrics, episodes)` of `updates_per_chunk`
    updates.

    Args:
      unroll: the compiled actor.
      learner: the learner.
      updates_per_chunk: U, the updates per call (>= 1).
      num_runs: None for one run; R for R runs (every leaf of the state then has a
        leading [R] axis, e.g. one learning rate per run), vmapped when scanned and
        else one after another.
      scan: run the U steps in `lax.scan` (None: on every backend but CPU).
      pipelined: act for the next batch while learning from the last (module
        docstring; U >= 2).

    Returns:
      The chunk, returning the new state, the learner's metrics, each float32[U] (or
      [R, U]), and the `EpisodeLog` of every step, leaves [U, K, B] (or [R, U, K, B]).

    Raises:
      ValueError: for a non-positive `updates_per_chunk` or `num_runs`, or a pipelined
        chunk of one update.
    """
    check_positive_int("updates_per_chunk", updates_per_chunk)
    if num_runs is not None:
        check_positive_int("num_runs", num_runs)
    scan = jax.default_backend() != "cpu" if scan is None else scan
    if pipelined:
        return _pipelined_chunk(unroll, learner, updates_per_chunk, num_runs, scan)
    step = make_train_step(unroll, learner)
    axis = 0 if num_runs is None else 1  # outputs are [U, ...] or [R, U, ...]
    if num_runs is not None and scan:
        step = jax.vmap(step)
    if scan:
        def scan_body(state: TrainState, _):
            state, metrics, episodes = step(state)
            return state, (metrics, episodes)

        def scanned(state: TrainState):
            state, outs = jax.lax.scan(scan_body, state, None, length=updates_per_chunk)
            return state, *jax.tree.map(lambda x: jnp.moveaxis(x, 0, axis), outs)

        return jax.jit(scanned, donate_argnums=0)

    compiled = _jitted_step(unroll, learner)
    if num_runs is not None:
        compiled = _run_by_run(compiled, num_runs)

    def looped(state: TrainState):
        outs = []
        for _ in range(updates_per_chunk):
            state, metrics, episodes = compiled(state)
            outs.append((metrics, episodes))
        return state, *jax.tree.map(lambda *xs: jnp.stack(xs, axis), *outs)

    return looped


def _pipelined_chunk(unroll: Unroll, learner: Learner, updates_per_chunk: int,
                     num_runs: int | None, scan: bool) -> ChunkFn:
    """`make_train_chunk`'s pipelined chunk: act, then U - 1 programs that each act and
    learn, then learn."""
    if updates_per_chunk < 2:
        raise ValueError(f"a pipelined chunk acts for the next update while it learns, so "
                         f"it needs updates_per_chunk >= 2, got {updates_per_chunk!r}")

    learn = functools.partial(_learn, learner)

    def act_and_learn(learner_state: LearnerState, actor: ActorState, trajectory):
        # Acting reads the parameters before this update: the two are independent.
        actor, following, episodes = unroll.unroll(learner_state.params, actor)
        learner_state, metrics = learn(learner_state, trajectory)
        return learner_state, actor, following, metrics, episodes

    def gather(first_episodes, middle, last_metrics):
        """Metrics [U] and episodes [U, K, B] from the first act, the U - 1 programs
        between (leaves [U - 1, ...]) and the last update."""
        metrics = jax.tree.map(lambda ms, m: jnp.concatenate([ms, m[None]]),
                               middle[0], last_metrics)
        episodes = jax.tree.map(lambda e, es: jnp.concatenate([e[None], es]),
                                first_episodes, middle[1])
        return metrics, episodes

    if scan:
        def chunk(state: TrainState):
            actor, trajectory, first = unroll.unroll(state.learner.params, state.actor)

            def body(carry, _):
                learner_state, actor, trajectory, metrics, episodes = act_and_learn(*carry)
                return (learner_state, actor, trajectory), (metrics, episodes)

            (learner_state, actor, trajectory), middle = jax.lax.scan(
                body, (state.learner, actor, trajectory), None, length=updates_per_chunk - 1)
            learner_state, last = learn(learner_state, trajectory)
            return (TrainState(learner_state, actor), *gather(first, middle, last))

        # A sweep's runs: leaves [R, ...] in and out, as the plain chunk's.
        return jax.jit(chunk if num_runs is None else jax.vmap(chunk), donate_argnums=0)

    act = jax.jit(unroll.unroll, donate_argnums=1)
    both = jax.jit(act_and_learn, donate_argnums=(0, 1, 2))
    last = jax.jit(learn, donate_argnums=0)
    stack = jax.jit(lambda *xs: jax.tree.map(lambda *x: jnp.stack(x), *xs))

    def looped(state: TrainState):
        actor, trajectory, first = act(state.learner.params, state.actor)
        learner_state, outs = state.learner, []
        for _ in range(updates_per_chunk - 1):
            learner_state, actor, trajectory, metrics, episodes = both(
                learner_state, actor, trajectory)
            outs.append((metrics, episodes))
        learner_state, metrics = last(learner_state, trajectory)
        return (TrainState(learner_state, actor),
                *gather(first, stack(*outs), metrics))

    return looped if num_runs is None else _run_by_run(looped, num_runs)


@functools.cache
def _jitted_step(unroll: Unroll, learner: Learner):
    """One run's step, jitted once per actor and learner, so that the chunks built from
    them (a run's, and a sweep's run by run) trace it once."""
    return jax.jit(make_train_step(unroll, learner), donate_argnums=0)


def _run_by_run(step, num_runs: int):
    """`step` (one run's compiled step) applied to each of `num_runs` runs in turn: the
    state's leaves are [R, ...] in and out, as the vmapped step's are."""
    take = jax.jit(lambda state, r: jax.tree.map(lambda x: x[r], state))
    stack = jax.jit(lambda *outs: jax.tree.map(lambda *xs: jnp.stack(xs), *outs))
    return lambda state: stack(*[step(take(state, r)) for r in range(num_runs)])
