"""sc2jax.losses: pure, jittable losses for the paper's agents.

The A3C n-step actor-critic loss (§4.1), its V-trace variant, PPO's clipped surrogate,
and the supervised value/policy loss and metrics of §5.
"""

from sc2jax.losses.actor_critic import (
    ActorCriticLossOutput,
    a3c_loss,
    entropy_regulariser,
    gae_targets,
    ppo_loss,
    vtrace_loss,
)
from sc2jax.losses.learner_loss import (
    OFF_POLICY_CORRECTIONS,
    Trajectory,
    make_actor_critic_loss,
    make_ppo_targets,
)
from sc2jax.losses.returns import n_step_returns, truncated_returns
from sc2jax.losses.supervised import (
    SupervisedBatch,
    SupervisedLossOutput,
    make_supervised_loss,
    supervised_loss,
    supervised_metrics,
)

# The time-major network unroll lives in `sc2jax.networks`; kept here for old imports.
from sc2jax.networks.unroll import unroll

__all__ = [name for name in dir() if not name.startswith("_")]
