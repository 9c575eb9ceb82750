"""One typed source of truth for every BPLIR parameter.

Every block is a frozen dataclass.  Each field carries its unit and allowed
range in ``field(metadata=...)``; ``__post_init__`` validates the block and
raises :class:`ParameterError` with a one-line message naming the field and
the allowed range.  Presets are looked up by name (:func:`preset`) and whole
parameter sets are read from / written to TOML (:func:`load_toml`,
:func:`to_toml`).

Nominal versus true: ``BplirParams.plant`` and ``BplirParams.friction`` are the
*nominal* model that controllers and estimators are built from.  The simulated
robot uses ``true_plant`` / ``true_friction`` when given (otherwise the
nominal blocks).  Controllers never receive the ``true_*`` blocks.

Dissertation sources: Table 4.3 (plant, friction), Table 4.2 and
(4.12)-(4.14) (motor), Table 5.1 and (5.36)-(5.40) (IMU, estimator), chapter
6 (controller), chapter 7 (path), docs/concepts.md (scenario and success criteria)."""
from __future__ import annotations

from .blocks import (
    INF, ParameterError, _p, _positive, MAX_LENGTH, _length, _fraction, _is_plugin, plugin_name, PLUGIN_GROUPS, registered_plugins, plugin_arguments, _range_text, _validate_block, _Block)
from .robot import (  # noqa: F401
    PlantParams,
    RobotFileParams,
    FrictionParams,
    MotorParams)
from .sensing import (  # noqa: F401
    ImuParams,
    LineSensorParams,
    sigma_from_density,
    EstimatorParams)
from .control import (  # noqa: F401
    TRAPEZOID_TUNING,
    IMU_ONLY_TUNING,
    LINE_SENSOR_OPTION,
    SUPPLY_48V_OPTION,
    HARDWARE_OPTIONS,
    CONTROLLER_PRESETS,
    RENAMED_PRESETS,
    current_preset_name,
    OUTER_LOOP_DESIGNS,
    ControllerParams,
    PATH_MODES,
    PathParams)
from .plan import (  # noqa: F401
    PLAN_INDEXING,
    LANDING_LAWS,
    PlanParams,
    HangingParams,
    LandingParams,
    moved_field,
    split_path_table)
from .scenario import (  # noqa: F401
    checked_seed,
    SEED_LIMIT,
    ScenarioParams,
    TRAVERSE_SWING_MODES,
    DriveParams,
    GripperParams,
    TraverseParams)
from .model import (  # noqa: F401
    BplirParams,
    swapped_plant,
    swapped_imu,
    swapped,
    parameter_reference,
    BLOCKS,
    _dissertation,
    _lab,
    PRESETS,
    preset)
from .follow import robot_scales, follow  # noqa: F401
from .derive import (  # noqa: F401
    Manoeuvre,
    derive,
    as_planned,
    on_line,
    with_hardware,
    imu_only,
    around,
    planned_from_hanging,
    free_link_tilt,
    free_link_upright,
    PUMP_TIME,
    TRAVERSE_END_SHARE,
    RETRY_TIME,
    RETRY_LIFT_HOLD,
    UPRIGHT_FREE_LINK)
from .files import (  # noqa: F401
    from_dict,
    read_toml,
    load_toml,
    to_dict,
    to_toml,
    save_toml,
    relative_files,
    as_jsonable)

__all__ = [
    "ParameterError", "PlantParams", "FrictionParams", "MotorParams", "ImuParams",
    "EstimatorParams", "LineSensorParams", "ControllerParams", "PathParams", "ScenarioParams",
    "BplirParams", "preset", "PRESETS", "HARDWARE_OPTIONS", "LINE_SENSOR_OPTION",
    "SUPPLY_48V_OPTION",
    "from_dict", "load_toml", "to_toml",
    "save_toml", "to_dict", "sigma_from_density", "DriveParams", "GripperParams", "TraverseParams",
    "PlanParams", "HangingParams", "LandingParams",
    "swapped", "Manoeuvre", "derive", "as_planned", "on_line", "with_hardware", "imu_only", "PUMP_TIME", "swapped_plant", "swapped_imu", "parameter_reference", "BLOCKS", "plugin_name",
]

