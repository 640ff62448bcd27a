"""Every transmission of the EPA Test Car Lists, built for the conventional simulator.

The lists' ``Tested Transmission Type Code`` and ``# of Gears`` choose a **family**
(:func:`family_of`); :func:`gearbox_blocks` writes the ``gearbox`` and ``converter`` blocks
of :class:`~vehval.vehicle.conventional.ConventionalVehicle` for it. The simulator has one
driveline loop (engine - coupling with lock-up - stepped ratios - final drive,
:mod:`vehval.sim.conventional_kernel`); each family is a setting of it:

* ``automatic`` (``A``, ``SA``; 3-10 gears): a torque converter sized by its stall speed,
  open in first and second gear, locked from third; ratios geometric over a spread
  typical of the gear count; shift lines from engine speeds. Unchanged from the first
  specs model (:mod:`vehval.epa.specs`).
* ``cvt`` (``CVT``, ``SCV``: a belt or chain CVT, with or without paddles): the lowest
  (overdrive) ratio from N/V, the ratio range over ``CVT_SPREAD`` (7.0: the Jatco CVT8 of
  2012 states a ratio coverage of 7.3, Toyota's Direct Shift-CVT of 2018 7.5, Honda's
  2.0 L CVT about 6.5), quasi-continuous as ``CVT_STEPS`` ratio steps that change in
  ``CVT_SHIFT_TIME_S``; the ratio follows an engine operating line, low speed at light load
  (``CVT_LINE_RPM`` at zero load, the efficient low-speed high-load region of a spark
  engine) rising to ``UPSHIFT_FULL`` x rated speed at full load; a torque converter for
  the launch, locked above ``CVT_LOCKUP_MPH`` (6 mph: CVTs lock up from a walking pace,
  their ratio range doing the converter's work; on the 2019 list's CVT cars the FTP-75
  reads -5.0 % with lock-up from 12 mph, -1.1 % from 6 mph, the HWFET +0.4 / +0.7 %); belt / chain and pump losses as the
  efficiency ``EFFICIENCY['cvt']`` (push-belt CVTs 0.85-0.93 over the part loads of a
  drive cycle: Srivastava and Haque, Mechanism and Machine Theory 44, 2009, a review).
* ``automated_manual`` (``AM``, ``AMS``: dual-clutch and single-clutch automated manuals,
  with or without paddles): no converter; the launch clutch is the simulator's coupling
  with its capacity set so that the peak torque passes at ``CLUTCH_LAUNCH_RPM`` of slip
  (the engine held near that speed while the clutch slips) and locked as soon as the
  clutch's output turns above idle; the automatic's shift lines and spread, a short
  shift time, a higher efficiency (no converter pump, wet or dry clutches).
* ``manual`` (``M``; 4-7 gears): the same clutch launch; upshifts by vehicle speed (a
  driver following a schedule: at full load only 25 % later): the speeds of 40 CFR
  86.128-79 for a manual transmission without the manufacturer's recommended shift
  speeds (first to second at 15 mph, second to third at 25, third to fourth at 40,
  fourth to fifth at 45 mph), higher gears when the next gear turns the engine at
  ``MANUAL_UPSHIFT_RPM`` or more; earlier when the engine reaches
  ``MANUAL_SHIFT_FROM_RPM`` (the recommended shift points of a modern six-speed, shown by
  its shift indicator, come at lower engine speeds than the CFR's speeds written for the
  three- and four-speed boxes of the 1970s: a six-speed with a tall top gear would turn
  3600 rpm at 15 mph in first); never an upshift that lugs the engine below
  ``MANUAL_MIN_RPM``. The lists' ``Shift Indicator Light Use`` says whether a shift
  indicator was used, not its shift points, so it does not enter the schedule.

Refused with the reason: ``OT`` (other: the power-split boxes of hybrids), an automatic
with one gear (an electric or hybrid drive), a gear count outside a family's range and an
unknown code.
"""

from __future__ import annotations

import math
from typing import Any

from vehval.constants import MPH_M_PER_S as MPH
from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.errors import ConfigError

#: transmission type code of the lists -> family
FAMILY_OF_CODE = {"A": "automatic", "SA": "automatic", "CVT": "cvt", "SCV": "cvt",
                  "AM": "automated_manual", "AMS": "automated_manual", "M": "manual"}
FAMILIES = ("automatic", "cvt", "automated_manual", "manual")
#: gear counts each stepped family is built for (a CVT's count is its paddle steps: unused)
GEAR_RANGE = {"automatic": (3, 10), "automated_manual": (4, 10), "manual": (4, 7)}
#: ratio spread (first / top) of production automatics by gear count
RATIO_SPREAD = {3: 2.8, 4: 4.0, 5: 4.9, 6: 6.0, 7: 7.0, 8: 7.6, 9: 9.2, 10: 10.0}
#: codes refused, with the reason
REFUSED_CODES = {"OT": "'OT' (other): the lists' code of hybrid power-split and special "
                       "drives, not a conventional gearbox"}
#: gearbox efficiency by family [-]: engineering estimates (converter automatics about
#: 0.95 with the pump; manual gearboxes 0.97; dual-clutch 0.96; push-belt CVTs 0.85-0.93)
EFFICIENCY = {"automatic": 0.95, "cvt": 0.90, "automated_manual": 0.96, "manual": 0.97}
#: minimum time between shifts [s]
SHIFT_TIME_S = {"automatic": 0.6, "cvt": 0.2, "automated_manual": 0.4, "manual": 1.0}
CVT_SPREAD = 7.0  # ratio range of a belt / chain CVT (lowest / overdrive) [-]
CVT_STEPS = 12  # ratio steps that stand for the continuous range [-]
CVT_SHIFT_TIME_S = SHIFT_TIME_S["cvt"]
CVT_LINE_RPM = 1100.0  # engine speed of the operating line at zero load [rpm]
CVT_LOCKUP_MPH = 6.0  # converter locked above this vehicle speed [mph]
CLUTCH_LAUNCH_RPM = 1500.0  # launch-clutch slip speed at peak torque [rpm]
MANUAL_SHIFT_MPH = (15.0, 25.0, 40.0, 45.0)  # 40 CFR 86.128-79: 1-2, 2-3, 3-4, 4-5 [mph]
MANUAL_UPSHIFT_RPM = 1500.0  # higher gears: the next gear turns the engine this fast [rpm]
MANUAL_SHIFT_FROM_RPM = 2200.0  # or earlier: upshift when the engine reaches this [rpm]
MANUAL_MIN_RPM = 1100.0  # no upshift below this engine speed in the next gear [rpm]
STALL_SPEED_RPM = 2500.0  # torque-converter stall speed at peak torque [rpm]
UPSHIFT_RPM, DOWNSHIFT_RPM = 1300.0, 1000.0  # at zero load, engine speed in the higher gear
#: at full load: upshift at this share of the rated speed, downshift below this share
UPSHIFT_FULL, DOWNSHIFT_FULL = 0.9, 0.6
LOCKUP_RPM = DOWNSHIFT_RPM  # locked above this engine speed [rpm]: on overrun to the downshift
LOCKUP_FROM_GEAR = 3  # lock-up from this gear: launches and 2nd gear through the converter
_EST = "engineering estimate (generic, vehval.epa.specs)"


def family_of(code: str, gears: int, where: str = "") -> str:
    """The transmission family of a list row's type ``code`` and gear count.

    Raises
    ------
    ConfigError
        One line naming ``where`` (the row), the code and the gear count.
    """
    code = (code or "").strip().upper()
    at = f"{where}: " if where else ""
    n = "1 gear" if gears == 1 else f"{gears} gears"
    if code in REFUSED_CODES:
        raise ConfigError(f"{at}transmission {REFUSED_CODES[code]} ({n}); not modelled from specs")
    fam = FAMILY_OF_CODE.get(code)
    if fam is None:
        known = ", ".join(sorted(FAMILY_OF_CODE))
        raise ConfigError(f"{at}unknown transmission type code '{code or '?'}' ({n}): the "
                          f"conventional model knows {known}; correct the list's 'Tested "
                          "Transmission Type Code'")
    lo, hi = GEAR_RANGE.get(fam, (0, 99))
    if not lo <= gears <= hi:
        raise ConfigError(f"{at}transmission '{code}' with {n}: the {fam.replace('_', ' ')} "
                          f"model has {lo}-{hi} gears (an automatic with one gear is an "
                          "electric or hybrid drive); not modelled from specs")
    return fam


def _v_at(rpm: float, overall: float, r: float) -> float:
    """Vehicle speed [m/s] at engine speed ``rpm`` in a gear of ``overall`` ratio."""
    return rpm * RPM * r / overall


def stepped_ratios(top: float, n: int, spread: float) -> list[float]:
    """``n`` gearbox ratios, first first, geometric from ``top`` x ``spread`` to ``top``."""
    return [top * spread ** ((n - 1 - i) / (n - 1)) for i in range(n)]


def _shift_lines(overall: list[float], r: float, rated_rpm: float, up_rpm: float,
                 down_rpm: float) -> dict[str, list[float]]:
    """Shift lines [m/s] from engine speeds: up at ``up_rpm`` in the next gear at no load
    and ``UPSHIFT_FULL`` x rated at full load; down below ``down_rpm`` / ``DOWNSHIFT_FULL``."""
    n = len(overall)
    up0 = [_v_at(up_rpm, overall[i + 1], r) for i in range(n - 1)]
    upf = [max(_v_at(UPSHIFT_FULL * rated_rpm, overall[i], r), up0[i] * 1.2)
           for i in range(n - 1)]
    dn0 = [_v_at(down_rpm, overall[i + 1], r) for i in range(n - 1)]
    dnf = [min(_v_at(DOWNSHIFT_FULL * rated_rpm, overall[i + 1], r), 0.8 * upf[i])
           for i in range(n - 1)]
    return {"upshift_speed_mps": up0, "upshift_speed_full_load_mps": upf,
            "downshift_speed_mps": dn0, "downshift_speed_full_load_mps": dnf}


def _manual_lines(overall: list[float], r: float, rated_rpm: float,
                  scale: float = 1.0) -> dict[str, list[float]]:
    """Manual shift lines: 40 CFR 86.128-79 speeds, then engine speeds (module docstring);
    ``scale`` multiplies the shift speeds and engine speeds (a later shift above 1)."""
    lines = _shift_lines(overall, r, rated_rpm, MANUAL_UPSHIFT_RPM * scale, DOWNSHIFT_RPM)
    up0 = lines["upshift_speed_mps"]
    for i in range(len(up0)):
        lug = _v_at(MANUAL_MIN_RPM, overall[i + 1], r)
        cfr = scale * MANUAL_SHIFT_MPH[i] * MPH if i < len(MANUAL_SHIFT_MPH) else up0[i]
        up0[i] = max(min(cfr, _v_at(scale * MANUAL_SHIFT_FROM_RPM, overall[i], r)), lug)
        if i:
            up0[i] = max(up0[i], up0[i - 1] * 1.05)
        lines["downshift_speed_mps"][i] = min(lines["downshift_speed_mps"][i], 0.8 * up0[i])
        # a driver shifts by vehicle speed: at full load only a little later
        lines["upshift_speed_full_load_mps"][i] = 1.25 * up0[i]
        lines["downshift_speed_full_load_mps"][i] = min(
            lines["downshift_speed_full_load_mps"][i], 0.8 * up0[i])
    return lines


def gearbox_blocks(family: str, top_gearbox: float, axle_ratio: float, gears: int,
                   wheel_radius_m: float, rated_rpm: float, peak_torque_nm: float,
                   ratio_source: str, efficiency: float | None = None,
                   upshift_scale: float = 1.0) -> tuple[dict[str, Any], dict[str, Any]]:
    """The ``gearbox`` and ``converter`` blocks of a family (module docstring).

    Parameters
    ----------
    family : str
        From :func:`family_of`.
    top_gearbox : float
        Top-gear (or lowest CVT) gearbox ratio [-], from N/V.
    axle_ratio, gears, wheel_radius_m, rated_rpm, peak_torque_nm
        Final drive [-], gear count, rolling radius [m], rated-power speed [rpm], peak
        torque [N·m].
    ratio_source : str
        Source text of the top ratio (N/V, axle ratio and the list row).
    efficiency : float, optional
        Gearbox efficiency [-]; default ``EFFICIENCY[family]``.
    upshift_scale : float
        Factor [-] on the family's upshift engine speeds (the CVT's operating line, the
        manual's shift speeds): the shift strategy of the technology coefficients; the
        upshift stays at least 10 % above the downshift speed.
    """
    r = wheel_radius_m
    k = float(upshift_scale)
    up_rpm = max(UPSHIFT_RPM * k, 1.1 * DOWNSHIFT_RPM)
    line_rpm = CVT_LINE_RPM * k
    eff = EFFICIENCY[family] if efficiency is None else float(efficiency)
    eff_src = (f"{family.replace('_', ' ')} gearbox: {_EST}" if efficiency is None
               else f"{family.replace('_', ' ')} gearbox: generic technology coefficients "
                    "(vehval.epa.technology)")
    if family == "cvt":
        n, spread = CVT_STEPS, CVT_SPREAD
        ratios = stepped_ratios(top_gearbox, n, spread)
        step = spread ** (1.0 / (n - 1))
        overall = [x * axle_ratio for x in ratios]
        lines = _shift_lines(overall, r, rated_rpm, line_rpm, line_rpm / math.sqrt(step))
        lock = [CVT_LOCKUP_MPH * MPH] * n
        ratio_src = (f"{ratio_source}; lowest (overdrive) ratio from N/V, the range over a "
                     f"spread {spread:g} (Jatco CVT8 7.3, Toyota Direct Shift-CVT 7.5) in "
                     f"{n} steps standing for the continuous ratio")
        line_src = (f"CVT operating line: the ratio that turns the engine at "
                    f"{line_rpm:g} rpm at no load, {UPSHIFT_FULL:g} x rated speed at "
                    f"full load: {_EST}")
        cap = peak_torque_nm / (STALL_SPEED_RPM * RPM) ** 2
        cap_src = f"launch converter, peak torque at a stall speed of {STALL_SPEED_RPM:g} rpm: {_EST}"
        lock_src = f"locked above {CVT_LOCKUP_MPH:g} mph in every ratio: {_EST}"
        shift_time, down_src = CVT_SHIFT_TIME_S, line_src
    else:
        spread = RATIO_SPREAD[gears]
        ratios = stepped_ratios(top_gearbox, gears, spread)
        overall = [x * axle_ratio for x in ratios]
        ratio_src = (f"{ratio_source}; the other {gears - 1} geometric over a ratio spread "
                     f"{spread:g} typical of {gears}-speed automatics: {_EST}")
        shift_time = SHIFT_TIME_S[family]
        if family == "automatic":
            lines = _shift_lines(overall, r, rated_rpm, up_rpm, DOWNSHIFT_RPM)
            lock = [100.0 if i + 1 < LOCKUP_FROM_GEAR else _v_at(LOCKUP_RPM, overall[i], r)
                    for i in range(gears)]
            cap = peak_torque_nm / (STALL_SPEED_RPM * RPM) ** 2
            cap_src = f"peak torque at a stall speed of {STALL_SPEED_RPM:g} rpm: {_EST}"
            lock_src = (f"locked from gear {LOCKUP_FROM_GEAR} above {LOCKUP_RPM:g} rpm "
                        f"(lower gears: never): {_EST}")
            line_src = f"engine at {up_rpm:g} rpm after the upshift: {_EST}"
            down_src = f"engine below {DOWNSHIFT_RPM:g} rpm: {_EST}"
        else:
            if family == "manual":
                lines = _manual_lines(overall, r, rated_rpm, k)
                line_src = ("40 CFR 86.128-79 manual shift speeds 15 / 25 / 40 / 45 mph"
                            + (f" x {k:.3g}" if k != 1.0 else "") + ", higher gears at "
                            f"{MANUAL_UPSHIFT_RPM * k:g} rpm in the next gear, earlier at "
                            f"{MANUAL_SHIFT_FROM_RPM * k:g} rpm, never below "
                            f"{MANUAL_MIN_RPM:g} rpm in the next gear")
            else:
                lines = _shift_lines(overall, r, rated_rpm, up_rpm, DOWNSHIFT_RPM)
                line_src = f"engine at {up_rpm:g} rpm after the upshift: {_EST}"
            down_src = f"engine below {DOWNSHIFT_RPM:g} rpm: {_EST}"
            lock = [0.0] * gears  # clutch closed whenever its output turns above idle
            cap = peak_torque_nm / (CLUTCH_LAUNCH_RPM * RPM) ** 2
            cap_src = (f"launch clutch (no converter): peak torque at {CLUTCH_LAUNCH_RPM:g} "
                       f"rpm of slip: {_EST}")
            lock_src = "clutch closed once its output turns above idle (launch slip below)"
    gearbox = {"ratios": ratios, "efficiency": eff, **lines, "shift_time_s": shift_time,
               "sources": {
                   "ratios": ratio_src, "efficiency": eff_src if family != "automatic"
                   or efficiency is not None else _EST,
                   "upshift_speed_mps": line_src,
                   "upshift_speed_full_load_mps": f"{UPSHIFT_FULL:g} x rated speed before the "
                                                  f"upshift: {_EST}",
                   "downshift_speed_mps": down_src,
                   "downshift_speed_full_load_mps": f"{DOWNSHIFT_FULL:g} x rated speed (at most "
                                                    f"0.8 x the upshift speed): {_EST}",
                   "shift_time_s": _EST}}
    converter = {"capacity_nm_s2_per_rad2": cap, "lockup_speed_mps": lock,
                 "sources": {"capacity_nm_s2_per_rad2": cap_src, "lockup_speed_mps": lock_src}}
    return gearbox, converter
