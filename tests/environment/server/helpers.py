"""What the server's tests share."""

from sc2jax.environment.sc2api.protos import sc2api


def join_beacon(controller, size=16):
    """`controller` creates MoveToBeacon (seed 5) and joins it at `size`² feature layers;
    returns the join's options."""
    controller.create_game(map_path="MoveToBeacon.SC2Map", random_seed=5)
    options = sc2api.InterfaceOptions(score=True)
    options.feature_layer.width = 24
    options.feature_layer.resolution.x = options.feature_layer.resolution.y = size
    options.feature_layer.minimap_resolution.x = size
    options.feature_layer.minimap_resolution.y = size
    controller.join_game(options)
    return options
