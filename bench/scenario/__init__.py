"""What to run: scenario files (TOML), their ``[[faults]]`` and ``[recording]`` tables, and the
typed, located field access every scenario-like file uses (errors name file, line and field).

The first stage of the data path: a scenario is parsed and checked against its motor profile
here, before any process or device is touched; ``hil_bench.loop`` runs it.
"""
from .fields import Fields, ScenarioError, line_of
from .scenario import (
    INV_COMP_CURRENTS,
    INV_COMP_SHAPES,
    RPM_PER_RAD_S,
    SCENARIO_DIR,
    Event,
    InverterComp,
    LinkSettings,
    RealtimeSettings,
    Scenario,
    check_against_profile,
    derive_scenario,
    load_scenario,
    load_torque_limit_nm,
    operator_limits,
    parse_scenario,
    resolve_path,
    scenario_of,
    speed_ref_at,
)

__all__ = ["Fields", "ScenarioError", "line_of", "RPM_PER_RAD_S", "SCENARIO_DIR", "Event",
           "INV_COMP_CURRENTS", "INV_COMP_SHAPES", "InverterComp",
           "LinkSettings", "RealtimeSettings", "Scenario", "check_against_profile", "operator_limits",
           "derive_scenario", "load_scenario", "load_torque_limit_nm", "parse_scenario",
           "resolve_path", "scenario_of", "speed_ref_at"]
