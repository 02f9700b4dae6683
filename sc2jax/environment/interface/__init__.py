"""PySC2's interface as data: argument types, functions, feature layers, observation tables,
specs, dense actions, the camera's transforms and the observation layouts.

It imports nothing else of sc2jax; the simulator, the real game's client and the networks
all build on it."""
