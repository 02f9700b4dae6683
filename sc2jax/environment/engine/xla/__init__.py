"""How the engine runs fast under XLA: computing only what a lane needs (`lazy`), fusion
barriers for XLA:CPU (`fusion`), counter-based random bits (`threefry`), and splitting a
batch over devices (`devices`)."""
