"""Checks of an identification's inputs and result: a declared specification that
contradicts itself (wheel radius against the tyre, rated power against peak torque), a
declared or template test mass far from the identified inertia, a fuel map that cannot be
right (refused, :class:`~vehval.errors.ConfigError`), and the warnings of a fuel map outside
the range of road engines or of identification tests that start cold (one line each)."""

from __future__ import annotations

from pathlib import Path

from vehval.constants import BRAKE_EFFICIENCY_RANGE, RPM_RAD_PER_S
from vehval.errors import ConfigError

RADIUS_TOL = 0.10   # [-] a rolling radius is within a few % of 0.97 x the unloaded radius


def check_radius(declared: dict) -> None:
    """A declared wheel radius far from the declared tyre's: a unit slip or another tyre (the
    radius would win silently and scale every gear ratio)."""
    if "tyre" not in declared or "wheel_radius_m" not in declared:
        return
    from vehval.identify.spec import tyre_radius_m
    tyre, r = declared["tyre"][0], float(declared["wheel_radius_m"][0])
    r_tyre = tyre_radius_m(tyre)
    if abs(r / r_tyre - 1) > RADIUS_TOL:
        raise ConfigError(
            f"identify: the declared wheel radius {r:.3f} m ({declared['wheel_radius_m'][2]}) "
            f"is {100 * (r / r_tyre - 1):+.0f} % from the rolling radius of the declared "
            f"{tyre} tyre ({r_tyre:.3f} m): give one of them, or the right one")


POWER_TOL = 0.02    # [-] rounding of published ratings


def check_power_torque(declared: dict) -> None:
    """The torque at rated power cannot exceed the peak torque: P_rated <= T_peak · ω_rated
    (within the rounding of published ratings); beyond, a unit slip (hp as kW, lb·ft as N·m)."""
    keys = ("rated_power_kw", "rated_speed_rpm", "peak_torque_nm")
    if not all(k in declared for k in keys):
        return
    p_kw, n_rpm, t_nm = (float(declared[k][0]) for k in keys)
    t_rated = p_kw * 1e3 / (n_rpm * RPM_RAD_PER_S)
    if t_rated > (1 + POWER_TOL) * t_nm:
        raise ConfigError(
            f"identify: a rated power of {p_kw:g} kW at {n_rpm:g} rpm needs {t_rated:.0f} N·m "
            f"there, above the declared peak torque {t_nm:g} N·m: is the power in hp (1 hp = "
            "0.7457 kW) or the torque in lb·ft (1 lb·ft = 1.356 N·m)?")


def check_mass(idf, declared: dict) -> None:
    """A declared test mass far from the identified inertia: another car's specification."""
    if "test_mass_kg" not in declared:
        return
    m_dec, m_id = float(declared["test_mass_kg"][0]), idf.road_load.values["mass_kg"]
    if abs(m_id / m_dec - 1) > 0.15:
        raise ConfigError(
            f"identify: the declared test mass {m_dec:.0f} kg ({declared['test_mass_kg'][2]}) "
            f"is far from the inertia identified from the tests ({m_id:.0f} kg): is the "
            "specification of another car?")


def check_template_mass(idf, template: Path) -> None:
    """The template's ``test_mass_kg`` against the inertia identified from the tests.

    The template's constant is the test mass every later stage uses (a template constant
    beats the vehicle's value: :mod:`vehval.conditions`), so a wrong one is refused here
    rather than written into the vehicle's record: the ratio tells a value in lb (or
    converted from lb twice) from another car's. The band is QA's gain of the force over
    ``test_mass_kg`` x acceleration (:data:`vehval.qa.crosscheck.MASS_GAIN_BAND`)."""
    from vehval.constants import LB_KG
    from vehval.qa.crosscheck import MASS_GAIN_BAND

    m_tpl = idf.road_load.template.get("mass_kg")
    m_id = idf.road_load.values["mass_kg"]
    if m_tpl is None or not m_tpl > 0:
        return
    lo, hi = MASS_GAIN_BAND
    gain = m_id / m_tpl
    if lo <= gain <= hi:
        return
    head = (f"identify: {template}: constants.test_mass_kg {m_tpl:g} is far from the inertia "
            f"identified from the tests ({m_id:.0f} kg, {gain:.3g} x it)")
    if lo <= gain / LB_KG <= hi:
        raise ConfigError(f"{head}: it is probably in lb ({m_tpl:g} lb = {m_tpl * LB_KG:.1f} kg): "
                          f"set test_mass_kg: {m_tpl * LB_KG:.1f}")
    if lo <= gain * LB_KG <= hi:
        raise ConfigError(f"{head}: it is probably converted from lb twice: set test_mass_kg: "
                          f"{m_tpl / LB_KG:.1f}")
    raise ConfigError(f"{head}: is the template of another car? Set the test (inertia) mass "
                      "of these tests")


UNIT_HINT = ("check the fuel flow's unit and the test fuel's heating value (template "
              "constants) and the fuel channel's mapping")


def check_fuel_map(idf, files) -> None:
    """A fuel map that explains the fuel worse than its mean, or burns less fuel than the
    work it gives (brake efficiency above 100 %): a unit or mapping mistake, refused."""
    from vehval.vehicle.maps import peak_brake_efficiency

    fm = idf.fuel_map
    eta = peak_brake_efficiency(idf.vehicle.engine)[0]
    tests = ", ".join(str(f) for f in files)
    if not fm.r2_5s >= 0.0:
        raise ConfigError(
            f"identify: the fuel map does not fit the measured fuel of {tests} (R² of 5 s "
            f"means {fm.r2_5s:.2f}: worse than a constant rate); {UNIT_HINT}")
    if not eta <= 1.0:
        raise ConfigError(
            f"identify: the fuel map of {tests} gives "
            + (f"{100 * eta:.0f} % brake efficiency (more work than the fuel's energy)"
               if eta == eta else "no fuel where the engine runs")
            + f"; {UNIT_HINT}")


def cold_warnings(traces, left_out=()) -> list[str]:
    """Identification tests that start cold and fit the warm fuel map (not in ``left_out``,
    the tests the map left out: with a standard warm test among them, every cold start is):
    their warm-up fuel goes into it."""
    from vehval.identify.warmup import cold_start_state
    cold = [(t.test_id, why) for t in traces for c, why in [cold_start_state(t)]
            if c and t.test_id not in left_out]
    if not cold:
        return []
    return [f"{', '.join(f'{tid} ({why})' for tid, why in cold)} "
            f"start{'s' if len(cold) == 1 else ''} cold: the warm fuel map takes in "
            f"{'its' if len(cold) == 1 else 'their'} warm-up fuel; identify from hot-start "
            "tests and give a cold start as --cold-test"]


def fuel_map_warnings(idf) -> list[str]:
    """A peak brake efficiency outside the range of road engines, in one line."""
    from vehval.vehicle.maps import brake_efficiency_plausible, peak_brake_efficiency

    eta, rpm, nm = peak_brake_efficiency(idf.vehicle.engine)
    if brake_efficiency_plausible(eta):
        return []
    lo, hi = BRAKE_EFFICIENCY_RANGE
    return [f"the identified fuel map peaks at {100 * eta:.1f} % brake efficiency ({rpm:.0f} "
            f"rpm, {nm:.0f} N·m), outside the {100 * lo:.0f}-{100 * hi:.0f} % of road "
            f"engines: {UNIT_HINT}"]


def check_declared(declared: dict) -> None:
    """The declared specification against itself (before any test is read)."""
    check_radius(declared)
    check_power_torque(declared)


def check_identification(idf, declared: dict, template: Path, files) -> None:
    """An identification against its declared specification, its template's test mass and
    the fuel it must explain (refused before anything is written)."""
    check_mass(idf, declared)
    check_template_mass(idf, template)
    check_fuel_map(idf, files)


def identification_warnings(idf, traces) -> list[str]:
    """The warnings of an identification: its fuel map's peak efficiency, cold tests."""
    return fuel_map_warnings(idf) + cold_warnings(traces, idf.fuel_left_out)
