"""Training on the simulator or the real game: the config and its flags and presets, actors,
the learner, the compiled and the split loops, checkpoints, evaluation and `train`."""
