"""The real game through the StarCraft II API: launching it, a websocket client, the proto
codecs of actions and observations, and `GameEnv`, the dm_env shell over a game.

It never imports the simulator (`engine`)."""
