"""`TrainConfig`: every setting of a training run, checked before anything is built.

Defaults follow the paper (§4.3): 64x64 feature layers, step_mul 8, K = 40, entropy
1e-3 for the function id and each argument, RMSProp with a learning rate annealed
linearly to half its initial value.
"""

from __future__ import annotations

import dataclasses

from sc2jax.checks import check_non_negative_int, check_positive_int
from sc2jax.environment.engine.minigames import check_map
from sc2jax.environment.engine.simulator import check_score_index
from sc2jax.environment.interface.specs import ObservationFormat
from sc2jax.environment.sc2_env import default_score_index, simulator_computer
from sc2jax.environment.sc2api.game_env import Bot
from sc2jax.experiments.training.actor import function_mask
from sc2jax.losses.learner_loss import OFF_POLICY_CORRECTIONS
from sc2jax.networks.factory import COMPUTE_DTYPES, NETWORKS, RAW_NETWORKS

BACKENDS = ("simulator", "sc2")


def _positive_float(name: str, value) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
        raise ValueError(f"{name} must be a positive number, got {value!r}")


@dataclasses.dataclass(frozen=True)
class TrainConfig:
    """A training run.

    Attributes:
      map_name: the mini-game (with backend "sc2", any map the game has).
      backend: "simulator" (the compiled loop: environments, actors and learner in one
        program) or "sc2": StarCraft II itself, one game process per environment,
        stepped by a host actor thread that feeds the learner (the split loop; its
        policy lags the learner's by up to 2 updates, which V-trace corrects).
      bot: the built-in AI opponent of a ladder map, (race, difficulty[, build]) as
        `game_env.Bot` takes them, e.g. ("terran", "easy") for the paper's full game;
        None: no opponent (on a ladder map, an idle one). The simulator's computer is
        a Terran of build "random" at difficulty very_easy, easy, medium or hard.
      score_index: the reward (simulator): None for the map's default (the mini-games'
        score; the outcome on ladder maps, as PySC2), or `Simulator.score_index`'s: -1
        the outcome, -2 the Blizzard score, k >= 0 `score_cumulative[k]`.
      reward_scale: multiplies the rewards the learner sees (the logged scores stay the
        game's): for rewards far from 1, such as the Blizzard score's.
      agent: the network: "atari", "fullyconv", "fullyconv_lstm" or "arfullyconv" (the
        feature interface), or "raw_fullyconv" (PySC2's raw interface: `raw_units`, the
        564 `RAW_FUNCTIONS`, the world point on a raw grid of minimap_size).
      max_units: rows of `raw_units` a raw network reads (more units than that are not
        seen, nor commanded).
      screen_size, minimap_size: feature-layer resolutions (16..256).
      screen_features, minimap_features: layer names (None: all of them).
      functions: restrict the agent's action set to these PySC2 function names (None:
        all 573, the paper's setting); availability still masks them.
      step_mul: game loops per agent step.
      num_envs: environments stepped together (the paper's 64 threads).
      unroll_length: K, agent steps per trajectory and update.
      total_steps: agent steps of the run, over all environments.
      learning_rate: the initial RMSProp learning rate.
      warmup_updates: updates over which the rate first rises linearly from 0 (0: none).
      discount: γ.
      value_weight: β.
      entropy_weight: η, for the function id and each argument.
      rmsprop_decay, rmsprop_epsilon: RMSProp's settings.
      non_point_rate_scale: multiplies the learning rate of every parameter outside the
        spatial-argument heads (1: the paper's single rate). Not for "arfullyconv", whose
        spatial heads are part of its autoregressive chain, nor "raw_fullyconv".
      max_grad_norm: global gradient-norm clipping (0: none).
      off_policy_correction: the policy gradient: "none" (A3C's n-step returns),
        "vtrace", or "ppo" (PPO's clipped surrogate, with GAE advantages fixed per batch
        and `ppo_epochs` passes over it).
      ppo_epochs: PPO's passes over each batch.
      ppo_minibatches: PPO's gradient steps per pass, each on 1/ppo_minibatches of the
        environments (num_envs must be a multiple).
      ppo_clip: PPO's ε.
      gae_lambda: GAE's λ for PPO.
      compute_dtype: the dtype of the network's convolutions and matmuls: "float32" or
        "bfloat16" (parameters, gradients and the optimiser stay float32).
      actor_device: None: act and learn one after the other in one compiled program
        (simulator). d: the environments and the policy run on this process's local
        device d beside the learner on device 0 (`device_actor`, the split loop: acting
        overlaps learning, the policy lags by up to 2 updates, which V-trace corrects;
        the environments are not checkpointed).
      pipelined: act for the next batch while learning from the last, in one compiled
        program per update (`compiled_loop`): the policy acts up to one update behind
        (use V-trace or PPO), and unlike actor_device the run keeps its environments in
        its checkpoints and resumes exactly (simulator, no actor_device,
        updates_per_chunk >= 2).
      seed: the run's seed (parameters, environments and actions).
      updates_per_chunk: updates between two host calls (logging).
      checkpoint_interval_s: seconds between checkpoints (one is always written at the end).
      eval_episodes: episodes of the final evaluation (0: none).
      best_eval_interval: how `train` chooses the best parameters it keeps. 0: by the
        mean of the last `SCORE_WINDOW` training episodes (free, but it lags the
        policy). N > 0: every N updates (at the first chunk end past each multiple)
        it evaluates the current parameters for `best_eval_episodes` fresh episodes,
        always with the same seed, and keeps the best of those (simulator only).
      best_eval_episodes: episodes of each of those evaluations.
      init_from: a run directory whose last parameters start this run instead of fresh
        ones: an A3C run, or a replay run (`train_replays`), of the same network,
        resolutions and layers. Read once, when the run starts (not on resuming).
    """

    map_name: str = "MoveToBeacon"
    backend: str = "simulator"
    bot: tuple[str, ...] | None = None
    score_index: int | None = None
    reward_scale: float = 1.0
    agent: str = "fullyconv"
    max_units: int = 64
    screen_size: int = 64
    minimap_size: int = 64
    screen_features: tuple[str, ...] | None = None
    minimap_features: tuple[str, ...] | None = None
    functions: tuple[str, ...] | None = None
    step_mul: int = 8
    num_envs: int = 32
    unroll_length: int = 40
    total_steps: int = 1_000_000
    learning_rate: float = 5e-4
    warmup_updates: int = 0
    discount: float = 0.99
    value_weight: float = 0.5
    entropy_weight: float = 1e-3
    rmsprop_decay: float = 0.99
    rmsprop_epsilon: float = 1e-5
    non_point_rate_scale: float = 1.0
    max_grad_norm: float = 10.0
    off_policy_correction: str = "none"
    ppo_epochs: int = 4
    ppo_minibatches: int = 1
    ppo_clip: float = 0.2
    gae_lambda: float = 0.95
    compute_dtype: str = "float32"
    actor_device: int | None = None
    pipelined: bool = False
    seed: int = 0
    updates_per_chunk: int = 10
    checkpoint_interval_s: float = 300.0
    eval_episodes: int = 100
    best_eval_interval: int = 0
    best_eval_episodes: int = 20
    init_from: str | None = None

    def __post_init__(self):
        if self.backend not in BACKENDS:
            raise ValueError(f"unknown backend {self.backend!r}; allowed: {list(BACKENDS)}")
        if not isinstance(self.map_name, str) or not self.map_name:
            raise ValueError(f"map_name must be a non-empty str, got {self.map_name!r}")
        if self.backend == "simulator":
            check_map(self.map_name, " (or any map of the game with backend 'sc2')")
        if self.bot is not None:
            if isinstance(self.bot, str) or not 1 <= len(self.bot) <= 3:
                raise ValueError(f"bot must be (race, difficulty[, build]), got {self.bot!r}")
            object.__setattr__(self, "bot", tuple(self.bot))
            if self.backend == "simulator":
                self.computer()
            else:
                self.opponent().setup()  # checks the race, difficulty and build
        if self.score_index is not None:
            if self.backend != "simulator":
                raise ValueError(f"score_index {self.score_index!r} needs backend "
                                 "'simulator' (the real game rewards as `make` does)")
            check_score_index(self.score_index)
        if self.agent not in NETWORKS:
            raise ValueError(f"unknown network {self.agent!r}; allowed: {sorted(NETWORKS)}")
        if self.off_policy_correction not in OFF_POLICY_CORRECTIONS:
            raise ValueError(f"unknown off_policy_correction {self.off_policy_correction!r}; "
                             f"allowed: {list(OFF_POLICY_CORRECTIONS)}")
        for name in ("screen_features", "minimap_features", "functions"):
            value = getattr(self, name)
            if isinstance(value, str):
                raise ValueError(f"{name} must be a sequence of layer names, got {value!r}")
            if value is not None:
                object.__setattr__(self, name, tuple(value))
        for name in ("step_mul", "num_envs", "unroll_length", "total_steps", "max_units",
                     "updates_per_chunk", "ppo_epochs", "ppo_minibatches"):
            check_positive_int(name, getattr(self, name))
        if self.num_envs % self.ppo_minibatches:
            raise ValueError(f"num_envs={self.num_envs} does not split into "
                             f"ppo_minibatches={self.ppo_minibatches}; use a divisor")
        if not 0.0 < self.ppo_clip < 1.0:
            raise ValueError(f"ppo_clip must be in (0, 1), got {self.ppo_clip!r}")
        if self.compute_dtype not in COMPUTE_DTYPES:
            raise ValueError(f"unknown compute_dtype {self.compute_dtype!r}; allowed: "
                             f"{list(COMPUTE_DTYPES)}")
        if not 0.0 <= self.gae_lambda <= 1.0:
            raise ValueError(f"gae_lambda must be in [0, 1], got {self.gae_lambda!r}")
        for name in ("learning_rate", "rmsprop_epsilon", "non_point_rate_scale",
                     "reward_scale", "checkpoint_interval_s"):
            _positive_float(name, getattr(self, name))
        for name in ("value_weight", "entropy_weight", "max_grad_norm"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)!r}")
        if self.agent in RAW_NETWORKS and self.backend != "simulator":
            raise ValueError(f"agent {self.agent!r} plays the raw interface, which needs "
                             f"backend 'simulator'; got {self.backend!r}")
        if self.non_point_rate_scale != 1.0 and self.agent in ("arfullyconv", *RAW_NETWORKS):
            raise ValueError(f"non_point_rate_scale={self.non_point_rate_scale!r} needs a "
                             f"network with point heads (atari, fullyconv, fullyconv_lstm), "
                             f"not {self.agent!r}; use 1")
        if not 0.0 <= self.discount <= 1.0:
            raise ValueError(f"discount must be in [0, 1], got {self.discount!r}")
        if not 0.0 <= self.rmsprop_decay < 1.0:
            raise ValueError(f"rmsprop_decay must be in [0, 1), got {self.rmsprop_decay!r}")
        if self.actor_device is not None:
            check_non_negative_int("actor_device", self.actor_device)
            if self.backend != "simulator":
                raise ValueError(f"actor_device={self.actor_device!r} needs backend "
                                 f"'simulator' (the real game's actors are its processes); "
                                 f"use None")
        if not isinstance(self.pipelined, bool):
            raise ValueError(f"pipelined must be a bool, got {self.pipelined!r}")
        if self.pipelined and (self.backend != "simulator" or self.actor_device is not None
                               or self.updates_per_chunk < 2):
            raise ValueError(
                f"pipelined=True acts beside learning inside a chunk of the compiled loop: it "
                f"needs backend 'simulator' (got {self.backend!r}), no actor_device (got "
                f"{self.actor_device!r}; the split loop already acts beside learning) and "
                f"updates_per_chunk >= 2 (got {self.updates_per_chunk!r})")
        for name in ("warmup_updates", "eval_episodes", "best_eval_interval"):
            check_non_negative_int(name, getattr(self, name))
        check_positive_int("best_eval_episodes", self.best_eval_episodes)
        if self.best_eval_interval and self.backend != "simulator":
            raise ValueError(f"best_eval_interval={self.best_eval_interval!r} needs backend "
                             f"'simulator' (on {self.backend!r} the evaluation would take "
                             f"the training games); use 0 there")
        if self.init_from is not None and (not isinstance(self.init_from, str)
                                           or not self.init_from):
            raise ValueError(f"init_from must be a run directory or None, got "
                             f"{self.init_from!r}")
        self.observation_format()  # checks the resolutions and layer names
        function_mask(self.functions, self.agent in RAW_NETWORKS)  # checks the action set

    def opponent(self) -> Bot | None:
        """The `game_env.Bot` of `bot`."""
        return None if self.bot is None else Bot(*self.bot)

    def computer(self) -> int:
        """The `Difficulty` of the simulator's computer that `bot` asks for (0: none)."""
        return simulator_computer(self.opponent(), self.map_name)

    def reward_index(self) -> int:
        """The simulator's `score_index` of `score_index` (None: the map's default)."""
        if self.score_index is not None:
            return self.score_index
        return default_score_index(self.map_name)

    def observation_format(self) -> ObservationFormat:
        raw = self.agent in RAW_NETWORKS
        return ObservationFormat(screen_size=self.screen_size, minimap_size=self.minimap_size,
                                 screen_features=self.screen_features,
                                 minimap_features=self.minimap_features,
                                 use_raw_units=raw, max_units=self.max_units,
                                 raw_resolution=self.minimap_size if raw else None,
                                 action_space="raw" if raw else "features")

    @property
    def steps_per_update(self) -> int:
        return self.unroll_length * self.num_envs

    @property
    def total_updates(self) -> int:
        """Updates of the run: total_steps rounded up to whole updates."""
        return -(-self.total_steps // self.steps_per_update)

    def to_json(self) -> dict:
        return dataclasses.asdict(self)

    @classmethod
    def from_json(cls, payload: dict) -> TrainConfig:
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(payload) - names)
        if unknown:
            raise ValueError(f"unknown config keys {unknown}; allowed: {sorted(names)}")
        return cls(**payload)


def parse_names(text: str | None) -> tuple[str, ...] | None:
    """A comma-separated flag value -> names ("" or "all" or None: all of them)."""
    if text is None or text.strip() in ("", "all"):
        return None
    return tuple(name.strip() for name in text.split(",") if name.strip())

