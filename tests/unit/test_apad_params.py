"""aPad parameters: names, ranges, float32 values from the wire."""

from __future__ import annotations

import numpy as np
import pytest

from apad_sitl.params import BY_NAME, PARAMS, ApadParams, ParamError, param_value, with_param


def test_names_fit_mavlink_and_defaults_describe_a_slow_apad() -> None:
    assert all(len(spec.name) <= 16 and spec.description for spec in PARAMS)
    p = ApadParams()
    assert (p.speed_max_mps, p.accel_max_mps2, p.wp_radius_m) == (0.5, 0.25, 1.0)
    assert (p.dock_reach_m, p.dock_time_s, p.undock_time_s) == (2.0, 10.0, 5.0)
    for name in ("SPEED_MAX", "ACCEL_MAX", "WP_RADIUS", "HOLD_KP", "HOLD_KD", "DOCK_REACH", "DOCK_TIME",
                 "UNDOCK_TIME", "YAW_RATE_MAX", "BATT_DRAIN_IDLE", "BATT_DRAIN_THR", "FS_GCS_TIMEOUT",
                 "SYSID_THISMAV"):
        assert name in BY_NAME
    assert BY_NAME["SYSID_THISMAV"].integral and not BY_NAME["SPEED_MAX"].integral


def test_with_param_sets_one_field_and_validates() -> None:
    p = with_param(ApadParams(), "SPEED_MAX", 0.3)
    assert p.speed_max_mps == 0.3 and param_value(p, "SPEED_MAX") == 0.3
    assert p.accel_max_mps2 == ApadParams().accel_max_mps2
    with pytest.raises(ParamError, match="outside"):
        with_param(p, "SPEED_MAX", 30.0)
    with pytest.raises(ParamError, match="not a number"):
        with_param(p, "SPEED_MAX", float("nan"))
    with pytest.raises(ParamError, match="not an integer"):
        with_param(p, "SYSID_THISMAV", 2.5)
    with pytest.raises(ParamError, match="unknown"):
        with_param(p, "NOPE", 1.0)
    with pytest.raises(ParamError):
        ApadParams(dock_reach_m=-1.0)


def test_float32_values_at_the_bounds_are_accepted() -> None:
    low = float(np.float32(BY_NAME["ACCEL_MAX"].min_value))  # 0.0099999998 after the wire
    assert low < BY_NAME["ACCEL_MAX"].min_value
    assert with_param(ApadParams(), "ACCEL_MAX", low).accel_max_mps2 == BY_NAME["ACCEL_MAX"].min_value
    assert with_param(ApadParams(), "SYSID_THISMAV", float(np.float32(7.0))).sysid_thismav == 7
