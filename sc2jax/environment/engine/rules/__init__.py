"""The game's rules over the unit arrays: state, unit data, geometry, commands, one game
loop of movement and combat, harvesting, production and the score."""
