"""The embedded simulator: pure, jittable `reset` and `step` over a state of fixed-size unit
arrays (`simulator`), the game's rules (`rules/`), the seven mini-games (`minigames/`), the
user interface, availability, rendering and observations, and XLA helpers (`xla/`)."""
