"""A generic battery-electric car (Leaf-sized) built in code for the BEV tests."""

from __future__ import annotations

from vehval.constants import LB_KG, LBF_N, MPH_M_PER_S
from vehval.vehicle.bev_generic import bev_vehicle_data

VALUES = dict(mass_kg=3625 * LB_KG, road_load_a_n=29.97 * LBF_N,
              road_load_b_n_per_mps=0.0713 * LBF_N / MPH_M_PER_S,
              road_load_c_n_per_mps2=0.02206 * LBF_N / MPH_M_PER_S ** 2, max_power_w=80_000.0,
              max_torque_nm=254.0, final_drive_ratio=8.19, wheel_radius_m=0.305,
              battery_kwh=24.0, cells_series=96)


def bev_data(**changes) -> dict:
    """Vehicle-file mapping of the test BEV (``changes`` replace values)."""
    vals = {**VALUES, **changes}
    return bev_vehicle_data(name="test_bev", description="generic test BEV", values=vals,
                            sources={k: "test value" for k in vals})
