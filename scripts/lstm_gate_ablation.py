"""Which loss term closes FullyConv LSTM's output gate (docs/results.md).

    python scripts/lstm_gate_ablation.py --block=value TRAIN_FLAGS   # then
    python scripts/lstm_output.py --run_dir=DIR

Trains as `python -m sc2jax.experiments.train TRAIN_FLAGS` does (`--network=fullyconv_lstm`),
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
from sc2jax.networks.outputs import NetworkOutput

_BLOCK = flags.DEFINE_enum("block", None, ["value", "policy"],
                           "the loss term whose gradient does not reach the ConvLSTM")


class BlockedHeads(fully_conv.FullyConvHeads):
    """`FullyConvHeads` with the gradient of the value or of the policy outputs stopped at
    `state`: the real heads, run twice in this module's own scope (the same parameters and
    outputs), once on `state` and once on a copy that passes no gradient."""

    def setup(self):
        self.heads = fully_conv.FullyConvHeads(self.spec, self.hidden)
        nn.share_scope(self, self.heads)

    def __call__(self, state: jax.Array) -> NetworkOutput:
        through, stopped = self.heads(state), self.heads(jax.lax.stop_gradient(state))
        value, policy = (stopped, through) if _BLOCK.value == "value" else (through, stopped)
        return policy._replace(value=value.value)


def main(argv):
    if flags.FLAGS.network != "fullyconv_lstm":
        raise app.UsageError(f"--network must be fullyconv_lstm, got {flags.FLAGS.network!r}")
    fully_conv_lstm.FullyConvHeads = BlockedHeads  # The class FullyConvLSTM builds.
    train.main(argv)


if __name__ == "__main__":
    flags.mark_flag_as_required("block")
    app.run(main)
