"""Which loss term closes FullyConv LSTM's output gate (docs/results.md).

    python scripts/lstm_gate_ablation.py --block=value TRAIN_FLAGS   # then
    python scripts/lstm_output.py --run_dir=DIR

Trains as `python -m sc2jax.experiments.train TRAIN_FLAGS` does (`--agent=fullyconv_lstm`),
except that one term's gradient stops at the heads' input, the ConvLSTM's output:
`--block=value` trains the torso and ConvLSTM on the policy and entropy terms alone (the
value head and the fully-connected layer still learn from the value term), and
`--block=policy` on the value term alone. The forward pass, the parameters and the
checkpoints are those of FullyConv LSTM, so `scripts/lstm_output.py` reads the run.
"""

import flax.linen as nn
import jax
from absl import app, flags

from sc2jax.experiments import train
from sc2jax.networks import fully_conv, fully_conv_lstm
from sc2jax.networks.heads import ConvPointHeads, ScalarArgumentHeads
from sc2jax.networks.outputs import ArgumentLogits, NetworkOutput

_BLOCK = flags.DEFINE_enum("block", None, ["value", "policy"],
                           "the loss term whose gradient does not reach the ConvLSTM")


class BlockedHeads(fully_conv.FullyConvHeads):
    """`FullyConvHeads` with the gradient of the value or of the policy outputs stopped at
    `state`; the same parameters and outputs."""

    @nn.compact
    def __call__(self, state: jax.Array) -> NetworkOutput:
        stopped = jax.lax.stop_gradient(state)
        value_in, policy_in = (stopped, state) if _BLOCK.value == "value" else (state, stopped)
        fc = nn.Dense(self.hidden, name="fc")

        def hidden(x):
            return nn.relu(fc(x.reshape(x.shape[0], -1)))

        h_value, h_policy = hidden(value_in), hidden(policy_in)
        args = {**ScalarArgumentHeads(self.spec, name="scalar_heads")(h_policy),
                **ConvPointHeads(self.spec, name="point_heads")(policy_in)}
        return NetworkOutput(
            value=nn.Dense(1, name="value")(h_value)[:, 0],
            function_logits=nn.Dense(self.spec.num_functions, name="function")(h_policy),
            argument_logits=ArgumentLogits(*(args[i] for i in range(len(args)))))


def main(argv):
    if flags.FLAGS.agent != "fullyconv_lstm":
        raise app.UsageError(f"--agent must be fullyconv_lstm, got {flags.FLAGS.agent!r}")
    fully_conv_lstm.FullyConvHeads = BlockedHeads  # The class FullyConvLSTM builds.
    train.main(argv)


if __name__ == "__main__":
    flags.mark_flag_as_required("block")
    app.run(main)
