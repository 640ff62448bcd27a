"""Flat layouts shared by the Python packer and the compiled time loop.

``PARAMS`` lists the scalar parameters packed in one float vector; ``SIGNALS`` the columns
of the recorded output (base names of the ``_simu`` signals); ``SUMMARY`` the entries of
the accumulator vector (energies [J], masses [kg], counts, extrema); ``STATE`` the entries
of the loop's state vector, which every phase of a step reads and writes (SI; flags and
states as 0/1 and small integers). ``CONV_PARAMS``, ``CONV_SIGNALS``, ``CONV_SUMMARY``: the
same three for the conventional loop; ``PAR_PARAMS``, ``PAR_SIGNALS``, ``PAR_SUMMARY`` for
the parallel-hybrid loop; ``BEV_PARAMS``, ``BEV_SIGNALS``, ``BEV_SUMMARY`` for the
battery-electric loop.
"""

from __future__ import annotations

PARAMS = (
    "mass", "rl_a", "rl_b", "rl_c", "aux_w", "r_wheel", "fd_ratio", "fd_eff", "j_wheel",
    "brk_max", "n_sun", "n_ring", "j_carrier", "j_ring",
    "j_eng", "eng_idle", "eng_max_spd", "eng_fire", "eng_drag", "eng_pmax", "fuel_lhv",
    "mot_tmax", "mot_pmax", "mot_max_spd", "j_mot",
    "gen_tmax", "gen_pmax", "gen_max_spd", "j_gen",
    "batt_cap_c", "boost_eff", "boost_vmax", "boost_vmin", "boost_full_spd",
    "soc_target", "soc_gain", "soc_pchg_max", "soc_pdis_max", "on_pwr", "on_pwr_hold",
    "off_pwr", "on_spd", "on_spd_hold", "off_spd", "batt_hold", "elec_eff", "off_hold",
    "soc_on", "soc_on_hold", "soc_force", "min_on", "min_off", "dis_margin", "chg_margin",
    "eng_min_pwr", "fuel_cut_pwr", "fuel_cut_spd", "regen_frac", "fade_lo", "fade_hi",
    "gen_kp", "gen_ki", "eng_pwr_tau", "gen_spd_margin", "eng_spd_margin",
    "drv_tau", "drv_ki", "drv_int_lim", "drv_fmax",
    "soc_init", "mg2_ratio", "op_system", "eq_factor",
    "cold_start", "cold_hold", "warm_frac", "warm_tau", "cold_pwr",
)
SIGNALS = (
    "veh_spd", "veh_spd_target", "veh_acc", "veh_frc_in", "veh_frc_loss", "whl_trq_out",
    "whl_spd", "eng_spd_out", "eng_trq_out", "eng_pwr_out", "eng_spd_target", "eng_on",
    "eng_fuel_cut", "fuel_rate", "gen_spd_out", "gen_trq_out", "gen_pwr_in", "mot_spd_out",
    "mot_trq_out", "mot_pwr_in", "ess_volt", "ess_curr", "ess_pwr", "ess_soc",
    "ess_pwr_lim_dis", "ess_pwr_lim_chg", "boost_volt_out", "brk_frc", "drv_pwr_demand",
    "drv_frc_demand", "pg_trq_ring", "eng_ctrl_state", "ess_pwr_lim_state",
)
SUMMARY = (
    "fuel_mass_kg", "fuel_energy_j", "ess_chem_energy_j", "ess_loss_j", "eng_loss_j",
    "mot_loss_j", "gen_loss_j", "boost_loss_j", "aux_energy_j", "fd_loss_j", "brake_energy_j",
    "road_energy_j", "lock_loss_j", "ke_start_j", "ke_end_j", "unmet_energy_j",
    "eng_out_energy_j", "distance_m", "eng_on_time_s", "engine_starts", "soc_final",
    "soc_min_seen", "soc_max_seen", "eng_spd_max", "gen_spd_max_abs", "mot_spd_max",
    "trace_max_miss_mps", "trace_n_miss", "state_switches", "duration_s",
    "tractive_energy_j", "regen_wheel_energy_j", "recirc_energy_j", "idle_fuel_energy_j",
    "gen_motoring_loss_j",
)
STATE = (
    # constants of the run, derived from the parameters once: planetary lever ratios
    # k1 = (Nr + Ns)/Ns, k2 = Nr/Ns [-], ring speed per vehicle speed g [rad/m], the
    # two-DOF mass matrix and its determinant, bounds and gains
    "dt", "k1", "k2", "g", "m11", "m12", "m22", "det", "f_min", "wg_lim", "ki_gen", "a_filt",
    "hold_s", "warm_frac", "cold_pwr",
    # carried from step to step
    "t", "t_mid", "v", "we", "soc", "locked", "eng_state", "eng_state_time", "tm_pwr", "tm_spd",
    "tm_bat", "tm_soc", "tm_off", "i_drv", "i_gen", "p_filt", "fired", "was_fired",
    # the present step: inputs, demands, limits, operating point, torques, speeds, powers
    "v0", "we0", "vnow", "vnext", "wr0", "wr_e", "f_dem", "p_wh", "p_tot", "ocv", "pdis_lim",
    "pchg_lim", "pdis_av", "pchg_av", "cmd_on", "p_cmd", "w_lo", "w_hi", "w_tgt", "p_eng",
    "fuelcut", "te_max", "wg0", "te", "tg_ff", "t_ring", "t_m", "tm_lim", "pstate", "f_brk",
    "fl", "we1", "v1", "t_g", "r_eff", "clipped", "eta_d", "we_a", "v_a", "wr_a", "wg_a",
    "fuel", "p_eng_mech", "p_gen_e", "p_mot_e", "t_fd_act", "f_fd", "fl_app", "brk_app",
    "p_bus", "p_bt", "rb", "cur", "vb", "wg1",
)
# the conventional loop (:mod:`vehval.sim.conventional_kernel`): parameters, recorded
# signals, summary accumulators
CONV_PARAMS = (
    "mass", "rl_a", "rl_b", "rl_c", "r_wheel", "fd_ratio", "fd_eff", "j_wheel", "brk_max",
    "gb_eff", "shift_time", "tc_k", "j_eng", "eng_idle", "eng_max_spd", "eng_drag",
    "eng_pmax", "fuel_lhv", "idle_fuel", "fuel_cut_spd", "overrun_fuel", "acc_pwr",
    "drv_tau", "drv_ki", "drv_int_lim", "drv_fmax", "idle_acc_pwr", "drag_a", "drag_b",
    "warm_frac", "warm_tau",
)
CONV_SIGNALS = (
    "veh_spd", "veh_spd_target", "veh_acc", "veh_frc_in", "veh_frc_loss", "whl_trq_out",
    "whl_spd", "eng_spd_out", "eng_trq_out", "eng_pwr_out", "eng_fuel_cut", "fuel_rate",
    "gb_gear", "gb_spd_in", "brk_frc", "drv_frc_demand", "drv_pwr_demand",
)
CONV_SUMMARY = (
    "fuel_mass_kg", "fuel_energy_j", "eng_out_energy_j", "eng_loss_j", "aux_energy_j",
    "eng_ke_change_j", "converter_loss_j", "gearbox_loss_j", "brake_energy_j", "road_energy_j",
    "ke_start_j", "ke_end_j", "wheel_energy_j", "distance_m", "idle_time_s",
    "fuel_cut_time_s", "unlocked_time_s", "gear_shifts", "eng_spd_max", "trace_max_miss_mps",
    "trace_n_miss", "duration_s",
)
# the parallel-hybrid loop (:mod:`vehval.sim.parallel_kernel`): parameters, recorded
# signals, summary accumulators
PAR_PARAMS = (
    "mass", "rl_a", "rl_b", "rl_c", "r_wheel", "fd_ratio", "fd_eff", "j_wheel", "brk_max",
    "gb_eff", "shift_time", "tc_k", "automatic", "j_eng", "j_mot", "eng_idle", "eng_max_spd",
    "eng_drag", "eng_pmax", "fuel_lhv", "fuel_cut_spd", "mech_acc", "elec_acc",
    "mot_tmax", "mot_pmax", "batt_cap_c", "soc_lo", "soc_hi", "soc_target",
    "assist_thr", "assist_min", "assist_slope", "assist_max", "assist_gear", "assist_soc",
    "regen_thr", "regen_frac", "regen_spd", "regen_soc", "charge_trq", "charge_band",
    "stop_spd", "stop_soc", "restart_j", "mot_idle_off",
    "drv_tau", "drv_ki", "drv_int_lim", "drv_fmax", "warm_frac", "warm_tau", "soc_init",
)
PAR_SIGNALS = (
    "veh_spd", "veh_spd_target", "veh_acc", "veh_frc_in", "veh_frc_loss", "whl_trq_out",
    "whl_spd", "eng_spd_out", "eng_trq_out", "eng_pwr_out", "eng_on", "eng_fuel_cut",
    "fuel_rate", "mot_spd_out", "mot_trq_out", "mot_pwr_in", "ess_volt", "ess_curr", "ess_pwr",
    "ess_soc", "gb_gear", "gb_spd_in", "brk_frc", "drv_frc_demand", "drv_pwr_demand",
)
PAR_SUMMARY = (
    "fuel_mass_kg", "fuel_energy_j", "ess_chem_energy_j", "ess_loss_j", "eng_out_energy_j",
    "eng_loss_j", "mot_loss_j", "aux_mech_energy_j", "aux_elec_energy_j", "restart_loss_j",
    "shaft_ke_change_j", "clutch_loss_j", "gearbox_loss_j", "brake_energy_j", "road_energy_j",
    "ke_start_j", "ke_end_j", "wheel_energy_j", "distance_m", "eng_on_time_s", "engine_starts",
    "assist_time_s", "regen_time_s", "assist_energy_j", "regen_energy_j", "ess_out_energy_j",
    "ess_in_energy_j", "soc_final", "soc_min_seen", "soc_max_seen", "gear_shifts",
    "eng_spd_max", "trace_max_miss_mps", "trace_n_miss", "duration_s",
)
# the battery-electric loop (:mod:`vehval.sim.bev_kernel`): parameters, recorded signals,
# summary accumulators
BEV_PARAMS = (
    "mass", "rl_a", "rl_b", "rl_c", "r_wheel", "fd_ratio", "fd_eff", "j_wheel", "brk_max",
    "aux_w", "j_mot", "mot_tmax", "mot_pmax", "mot_max_spd", "batt_cap_c", "soc_init",
    "soc_min", "soc_max", "regen_pmax", "regen_fade_lo", "regen_fade_hi", "regen_share",
    "drv_tau", "drv_ki", "drv_int_lim", "drv_fmax",
)
BEV_SIGNALS = (
    "veh_spd", "veh_spd_target", "veh_acc", "veh_frc_in", "veh_frc_loss", "whl_trq_out",
    "whl_spd", "mot_spd_out", "mot_trq_out", "mot_pwr_in", "ess_volt", "ess_curr", "ess_pwr",
    "ess_soc", "ess_pwr_lim_dis", "ess_pwr_lim_chg", "brk_frc", "drv_frc_demand",
    "drv_pwr_demand",
)
BEV_SUMMARY = (
    "ess_chem_energy_j", "ess_dc_energy_j", "ess_dc_discharge_j", "ess_dc_charge_j",
    "ess_loss_j", "mot_loss_j", "mot_out_energy_j", "regen_mech_energy_j", "aux_energy_j",
    "fd_loss_j", "brake_energy_j", "road_energy_j", "wheel_energy_j", "ke_start_j", "ke_end_j",
    "unmet_energy_j", "distance_m", "soc_final", "soc_min_seen", "trace_max_miss_mps",
    "trace_n_miss", "duration_s",
)

P = {n: i for i, n in enumerate(PARAMS)}
S = {n: i for i, n in enumerate(SIGNALS)}
Y = {n: i for i, n in enumerate(SUMMARY)}
X = {n: i for i, n in enumerate(STATE)}
