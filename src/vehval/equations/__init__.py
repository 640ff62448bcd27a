"""Powertrain relations (pure functions), a safe expression language and the calculation
engine that derives ``*_calc`` signals from measured ones."""

from vehval.equations.powertrain import (  # noqa: F401
    cumint,
    deriv,
    efficiency,
    final_drive_input_speed,
    fuel_power,
    motor_torque,
    power,
    ring_torque,
    road_load,
    smooth,
    sun_torque,
    vehicle_force_in,
    vehicle_force_out,
    wheel_speed_from_vehicle,
    wheel_torque,
    willis_eng_speed,
    willis_gen_speed,
    willis_mot_speed,
)
