"""PySC2's `pysc2.lib.features`: the feature layers, the observation tables' enums, and
the agent interface format (`Dimensions`, `AgentInterfaceFormat`,
`parse_agent_interface_format`).

The simulator renders the feature layers at any resolution in 16..256 (PySC2's usual 84
and 64 included) with a camera 24 world units wide; the other interfaces (RGB, raw
actions, unit counts, the camera position) are refused by name.
"""

from __future__ import annotations

import dataclasses

from sc2jax.environment.interface.arguments import normalize_size
from sc2jax.environment.interface.camera import CAMERA_WIDTH
from sc2jax.environment.interface.features import (
    MINIMAP_FEATURES,
    SCREEN_FEATURES,
    Feature,
    FeatureType,
    PlayerRelative,
    Visibility,
)
from sc2jax.environment.interface.observation_tables import (
    ControlGroup,
    FeatureUnit,
    Player,
    ProductionQueue,
    ScoreByCategory,
    ScoreByVital,
    ScoreCategories,
    ScoreCumulative,
    ScoreVitals,
    UnitLayer,
)
from sc2jax.environment.interface.specs import MAX_RESOLUTION, MIN_RESOLUTION
from sc2jax.environment.pysc2.lib.actions import ActionSpace

__all__ = ["MINIMAP_FEATURES", "SCREEN_FEATURES", "ActionSpace", "AgentInterfaceFormat",
           "ControlGroup", "Dimensions", "Feature", "FeatureType", "FeatureUnit", "Player",
           "PlayerRelative", "ProductionQueue", "ScoreByCategory", "ScoreByVital",
           "ScoreCategories", "ScoreCumulative", "ScoreVitals", "UnitLayer", "Visibility",
           "parse_agent_interface_format"]

@dataclasses.dataclass(frozen=True)
class Dimensions:
    """Screen and minimap resolutions: an int (square) or (x, y) each."""

    screen: int | tuple[int, int] | None = None
    minimap: int | tuple[int, int] | None = None

    def __post_init__(self):
        if self.screen is None or self.minimap is None:
            raise ValueError(f"Dimensions needs both screen and minimap, got "
                             f"screen={self.screen!r}, minimap={self.minimap!r}")
        for name in ("screen", "minimap"):
            object.__setattr__(self, name, normalize_size(
                getattr(self, name), name, MIN_RESOLUTION, MAX_RESOLUTION))


@dataclasses.dataclass(frozen=True)
class AgentInterfaceFormat:
    """What the agent observes and how it acts, as PySC2's `AgentInterfaceFormat`.

    The options the simulator has: `feature_dimensions` (required), `use_feature_units`,
    `use_raw_units`, `allow_cheating_layers`, `hide_specific_actions` (True: PySC2's
    default, general functions only), `max_selected_units` (rows of `multi_select`),
    `camera_width_world_units` (None or 24), and the raw interface: `action_space`
    `ActionSpace.RAW` or `use_raw_actions` (with `use_raw_units`, as PySC2's), and
    `raw_resolution`. The others must keep PySC2's defaults.

    Raises:
      ValueError: an option the simulator does not have, or a bad value, naming it.
    """

    feature_dimensions: Dimensions | None = None
    rgb_dimensions: Dimensions | None = None
    raw_resolution: object = None
    action_space: ActionSpace | None = None
    camera_width_world_units: float | None = None
    use_feature_units: bool = False
    use_raw_units: bool = False
    use_raw_actions: bool = False
    max_raw_actions: int = 512
    max_selected_units: int = 30
    use_unit_counts: bool = False
    use_camera_position: bool = False
    show_cloaked: bool = False
    show_burrowed_shadows: bool = False
    show_placeholders: bool = False
    hide_specific_actions: bool = True
    action_delay_fn: object = None
    send_observation_proto: bool = False
    crop_to_playable_area: bool = False
    raw_crop_to_playable_area: bool = False
    allow_cheating_layers: bool = False
    add_cargo_to_units: bool = False

    def __post_init__(self):
        if not isinstance(self.feature_dimensions, Dimensions):
            raise ValueError(f"feature_dimensions must be a features.Dimensions (the "
                             f"simulator observes feature layers), got "
                             f"{self.feature_dimensions!r}")
        if self.action_space not in (None, ActionSpace.FEATURES, ActionSpace.RAW):
            raise ValueError(f"action_space {self.action_space} is not supported; the "
                             f"simulator takes feature-layer or raw actions "
                             f"(ActionSpace.FEATURES or ActionSpace.RAW)")
        if self.use_raw_actions and self.action_space == ActionSpace.FEATURES:
            raise ValueError("Don't specify both an action_space and use_raw_actions.")
        if self.raw and not self.use_raw_units:
            raise ValueError("You must set use_raw_units if you intend to use_raw_actions")
        if self.camera_width_world_units not in (None, CAMERA_WIDTH):
            raise ValueError(f"camera_width_world_units={self.camera_width_world_units!r} "
                             f"is not supported; the simulator's camera is {CAMERA_WIDTH:g} "
                             f"world units wide (None or {CAMERA_WIDTH:g})")
        if not self.hide_specific_actions:
            raise ValueError("hide_specific_actions=False is not supported: the simulator "
                             "lists the general functions only (PySC2's default, True)")
        if not isinstance(self.max_selected_units, int) or self.max_selected_units < 1:
            raise ValueError(f"max_selected_units must be a positive int, got "
                             f"{self.max_selected_units!r}")
        unsupported = [f.name for f in dataclasses.fields(self) if f.name in _UNSUPPORTED
                       and getattr(self, f.name) != f.default]
        if unsupported:
            raise ValueError(f"{', '.join(unsupported)}: not supported by the simulator; "
                             f"leave {'it' if len(unsupported) == 1 else 'them'} at PySC2's "
                             f"default")

    @property
    def raw(self) -> bool:
        """Whether the agent acts through the raw interface (`RAW_FUNCTIONS`)."""
        return self.use_raw_actions or self.action_space == ActionSpace.RAW


_UNSUPPORTED = ("rgb_dimensions", "max_raw_actions",
                "use_unit_counts", "use_camera_position", "show_cloaked",
                "show_burrowed_shadows", "show_placeholders", "action_delay_fn",
                "send_observation_proto", "crop_to_playable_area",
                "raw_crop_to_playable_area", "add_cargo_to_units")


def parse_agent_interface_format(feature_screen=None, feature_minimap=None, rgb_screen=None,
                                 rgb_minimap=None, action_space=None, action_delays=None,
                                 **kwargs) -> AgentInterfaceFormat:
    """An `AgentInterfaceFormat` from flat options, as PySC2's (the flags of its
    `bin/agent`): `feature_screen` and `feature_minimap` resolutions, `action_space` as
    a name or an `ActionSpace`, and the format's other options as keywords.

    Raises:
      ValueError: RGB or delayed actions, or a bad option (see `AgentInterfaceFormat`).
    """
    if rgb_screen or rgb_minimap:
        raise ValueError(f"rgb_screen={rgb_screen!r}, rgb_minimap={rgb_minimap!r}: the "
                         f"simulator has no RGB observations")
    if action_delays:
        raise ValueError(f"action_delays={action_delays!r}: not supported by the simulator")
    if isinstance(action_space, str):
        if action_space.upper() not in ActionSpace.__members__:
            raise ValueError(f"action_space {action_space!r} is not one of "
                             f"{list(ActionSpace.__members__)}")
        action_space = ActionSpace[action_space.upper()]
    if feature_screen is None and feature_minimap is None:
        raise ValueError("parse_agent_interface_format needs feature_screen and "
                         "feature_minimap (the simulator observes feature layers)")
    return AgentInterfaceFormat(
        feature_dimensions=Dimensions(screen=feature_screen, minimap=feature_minimap),
        action_space=action_space, **kwargs)
