"""arFullyConv: FullyConv with an autoregressive policy (paper §4.2 and §5.2).

π(a|s) = Π_l π(a^l | a^{<l}, s): the function id a⁰ first, then the 13 argument types
in `TYPES` order, each conditioned on a⁰ and on the arguments chosen before it that
a⁰ uses. The conditioning vector of argument l is

    c_l = E_fn(a⁰) + Σ_{k<l, k used by a⁰} E_k(a^k)          [B, D]

(E_k embeds a scalar value, or a point as E_k^x(x) + E_k^y(y)). It enters each head
before a non-linearity, so it changes the shape of the distribution, not only its
offset:

- scalar argument l: logits = W_l relu(h + U_l c_l), h the 256-unit FC layer;
- point argument l: logits = conv1x1_l(relu(P + c_l)), P a shared 1x1 projection of
  the state to D channels (resized to the minimap resolution for minimap points).

`__call__(obs, action)` gives teacher-forced logits (for supervised learning and
for the log-probabilities of a loss); `sample` draws a⁰, then each argument in turn.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import flax.linen as nn
import jax
import jax.numpy as jnp

from sc2jax.environment.interface.dense import DenseAction
from sc2jax.networks.fully_conv import FullyConvTorso
from sc2jax.networks.heads import pixel_logits, resize
from sc2jax.networks.outputs import ArgumentLogits, NetworkOutput, as_float32
from sc2jax.networks.policy import (
    argument_sample,
    choose,
    gumbel_noise,
    mask_function_logits,
    used_arguments,
    zero_unused,
)
from sc2jax.networks.spec import NetworkSpec


class ARFullyConv(nn.Module):
    """The arFullyConv network.

    Attributes:
      spec: input and output sizes (`NetworkSpec.from_format(fmt)`).
      hidden: units of the fully-connected layer (256).
      embed_dim: D, the size of the action embeddings and the spatial projection.
      dtype: the computation dtype of every layer (the parameters and outputs stay
        float32).
    """

    spec: NetworkSpec
    hidden: int = 256
    embed_dim: int = 32
    dtype: Any = jnp.float32

    def setup(self):
        sizes = self.spec.argument_sizes
        self.torso = FullyConvTorso(self.spec, self.dtype)
        self.fc = nn.Dense(self.hidden, dtype=self.dtype)
        self.value_head = nn.Dense(1, dtype=self.dtype)
        self.function_head = nn.Dense(self.spec.num_functions, dtype=self.dtype)
        self.function_embed = nn.Embed(self.spec.num_functions, self.embed_dim, dtype=self.dtype)
        self.spatial_proj = nn.Conv(self.embed_dim, (1, 1), dtype=self.dtype)
        embeds, heads, conds = [], [], []
        for i, size in enumerate(sizes):
            if len(size) == 2:
                embeds.append((nn.Embed(size[0], self.embed_dim, dtype=self.dtype,
                                        name=f"embed_{i}_x"),
                               nn.Embed(size[1], self.embed_dim, dtype=self.dtype,
                                        name=f"embed_{i}_y")))
                heads.append(nn.Conv(1, (1, 1), dtype=self.dtype, name=f"arg_{i}"))
                conds.append(None)
            else:
                embeds.append(nn.Embed(size[0], self.embed_dim, dtype=self.dtype,
                                       name=f"embed_{i}"))
                heads.append(nn.Dense(size[0], dtype=self.dtype, name=f"arg_{i}"))
                conds.append(nn.Dense(self.hidden, dtype=self.dtype, name=f"cond_{i}"))
        self.arg_embeds, self.arg_heads, self.arg_conds = embeds, heads, conds

    def _body(self, obs: Mapping[str, jax.Array]):
        state = self.torso(obs)
        h = nn.relu(self.fc(state.reshape(state.shape[0], -1)))
        return (state, h, *as_float32((self.value_head(h)[:, 0], self.function_head(h))))

    def _embed(self, i: int, value: jax.Array) -> jax.Array:
        if len(self.spec.argument_sizes[i]) == 2:
            ex, ey = self.arg_embeds[i]
            return ex(value[..., 0]) + ey(value[..., 1])
        return self.arg_embeds[i](value)

    def _arguments(self, state, h, function, given, noise, temperature):
        """Runs the argument heads in order; samples (with `noise`) where `given` is None."""
        used = used_arguments(function)
        cond = self.function_embed(function)
        proj = self.spatial_proj(state)
        noise = [None] * 13 if noise is None else noise
        logits, values = [], []
        for i, size in enumerate(self.spec.argument_sizes):
            if len(size) == 2:
                p = resize(proj, size)
                lg = pixel_logits(self.arg_heads[i](nn.relu(p + cond[:, None, None, :])))
            else:
                lg = self.arg_heads[i](nn.relu(h + self.arg_conds[i](cond)))
            lg = as_float32(lg)
            if given is None:
                value = zero_unused(argument_sample(noise[i], lg, temperature), used[:, i])
            else:
                value = jnp.asarray(given.arguments[i]).astype(jnp.int32)
            cond = cond + jnp.where(used[:, i:i + 1], self._embed(i, value), 0.0)
            logits.append(lg)
            values.append(value)
        return ArgumentLogits(*logits), values

    def __call__(self, obs: Mapping[str, jax.Array],
                 action: DenseAction | None = None) -> NetworkOutput:
        """Teacher-forced outputs.

        Args:
          obs: padded observations with a batch dim [B, ...] (see `FullyConv`).
          action: the `DenseAction` [B...] to condition on (e.g. the replay target or
            the action taken); None conditions on an all-zero action (no_op).

        Returns:
          `NetworkOutput` whose argument logits are π(a^l | a^{<l}, a⁰, s) for the given
          action; `PixelLogits` for point types, [B, n] for scalar types.
        """
        state, h, value, function_logits = self._body(obs)
        b = state.shape[0]
        if action is None:
            function = jnp.zeros((b,), jnp.int32)
            action = DenseAction(function, *(jnp.zeros((b, 2) if len(s) == 2 else (b,),
                                                       jnp.int32)
                                             for s in self.spec.argument_sizes))
        if not isinstance(action, DenseAction):
            raise TypeError(f"action must be a DenseAction or None, got {type(action).__name__}")
        function = jnp.asarray(action.function).astype(jnp.int32)
        args, _ = self._arguments(state, h, function, action, None, 1.0)
        return NetworkOutput(value, function_logits, args)

    def sample(self, obs: Mapping[str, jax.Array], key: jax.Array | None,
               temperature: float | jax.Array = 1.0) -> tuple[DenseAction, NetworkOutput]:
        """Samples a⁰ from the masked function distribution, then each argument in turn.

        Args:
          obs: padded observations [B, ...], including available_actions_mask [B, F].
          key: a PRNG key, or None for greedy choices at every level.
          temperature: softmax temperature (> 0).

        Returns:
          (the `DenseAction` of int32, unused arguments 0; the `NetworkOutput` whose
          argument logits are conditioned on the sampled prefix, so that
          `policy.log_prob(output, action, ...)` is the behaviour log-probability).
        """
        state, h, value, function_logits = self._body(obs)
        noise = [None] * 14
        if key is not None:  # one draw for every head (see `policy.gumbel_noise`)
            sizes = ((self.spec.num_functions,),) + tuple(
                (s[0] * s[1],) if len(s) == 2 else s for s in self.spec.argument_sizes)
            noise = gumbel_noise(key, function_logits.shape[:-1], sizes)
        masked = mask_function_logits(function_logits, jnp.asarray(obs["available_actions_mask"]))
        function = choose(None if key is None else noise[0][0], masked, temperature)
        args, values = self._arguments(state, h, function, None,
                                       None if key is None else noise[1:], temperature)
        return DenseAction(function, *values), NetworkOutput(value, function_logits, args)
