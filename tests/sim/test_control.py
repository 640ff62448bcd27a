"""Engine state machine: every transition reached with crafted inputs; hold timers."""

from __future__ import annotations

import itertools

import pytest

from vehval.sim.control import (
    ENG_OFF,
    ENG_OFF_MINTIME,
    ENG_ON,
    ENG_ON_MINTIME,
    STATE_NAMES,
    engine_commanded_on,
    held,
    hold_timer,
    regen_fade,
    soc_power_demand,
    state_step,
)

DT, MIN_ON, MIN_OFF = 0.1, 5.0, 3.0


def step(state, t, on=False, off=False, force=False):
    return state_step(state, t, on, off, force, DT, MIN_ON, MIN_OFF)


# (from, inputs, time in state, expected to) for every edge of the state machine
CASES = [
    (ENG_OFF, {}, 10.0, ENG_OFF),
    (ENG_OFF, {"on": True}, 10.0, ENG_ON_MINTIME),
    (ENG_OFF, {"force": True}, 10.0, ENG_ON_MINTIME),
    (ENG_ON_MINTIME, {"off": True}, 1.0, ENG_ON_MINTIME),      # min on time not over
    (ENG_ON_MINTIME, {}, MIN_ON - DT, ENG_ON),                 # min on time reached
    (ENG_ON, {}, 10.0, ENG_ON),
    (ENG_ON, {"off": True}, 10.0, ENG_OFF_MINTIME),
    (ENG_ON, {"off": True, "force": True}, 10.0, ENG_ON),      # low SOC keeps it on
    (ENG_OFF_MINTIME, {"on": True}, 1.0, ENG_OFF_MINTIME),     # min off time not over
    (ENG_OFF_MINTIME, {"force": True}, 1.0, ENG_ON_MINTIME),   # critical SOC overrides
    (ENG_OFF_MINTIME, {}, MIN_OFF - DT, ENG_OFF),              # min off time reached
]


@pytest.mark.parametrize("src, inputs, t, dst", CASES)
def test_transition(src, inputs, t, dst):
    new, t_new = step(src, t, **inputs)
    assert new == dst, f"{STATE_NAMES[src]} -> {STATE_NAMES[new]}, expected {STATE_NAMES[dst]}"
    if new != src and new in (ENG_ON_MINTIME, ENG_OFF_MINTIME):
        assert t_new == 0.0  # a new timed state starts its clock


def test_every_transition_reachable_and_no_other():
    """Exhaustive inputs: the set of reachable edges is exactly the designed one."""
    designed = {(s, d) for s, _, _, d in CASES}
    seen = set()
    for s in range(4):
        for on, off, force in itertools.product([False, True], repeat=3):
            for t in (0.0, 1.0, 100.0):
                seen.add((s, step(s, t, on, off, force)[0]))
    assert seen == designed
    assert all(s != d for s, d in designed - {(x, x) for x in range(4)})
    assert {d for _, d in designed} == set(range(4))  # every state entered


def test_minimum_times_prevent_oscillation():
    """Requests toggling every step: the engine switches no faster than the minimum times."""
    st, t, switches, on_prev = ENG_OFF, 0.0, [], False
    for k in range(2000):
        on = k % 2 == 0
        st, t = step(st, t, on=on, off=not on)
        if engine_commanded_on(st) != on_prev:
            switches.append((k * DT, engine_commanded_on(st)))
            on_prev = engine_commanded_on(st)
    assert len(switches) > 10
    for (t0, was_on), (t1, _) in zip(switches[:-1], switches[1:]):
        # an on period lasts at least min_on, an off period at least min_off (dt tolerance)
        assert t1 - t0 >= (MIN_ON if was_on else MIN_OFF) - 1e-9
    assert engine_commanded_on(ENG_ON) and engine_commanded_on(ENG_ON_MINTIME)
    assert not engine_commanded_on(ENG_OFF) and not engine_commanded_on(ENG_OFF_MINTIME)


def test_hold_timer_counts_only_after_hold_time():
    t = 0.0
    for _ in range(4):
        t = hold_timer(t, True, 0.1)
    assert not held(t, 0.5) and held(hold_timer(t, True, 0.1), 0.5)
    assert hold_timer(t, False, 0.1) == 0.0  # a break resets the timer


def test_soc_regulation_and_regen_fade():
    # 150 kW per unit SOC, 5 % below target -> 7.5 kW charging demand (bounded by 8 kW)
    assert soc_power_demand(0.55, 0.6, 150e3, 8e3, 4e3) == pytest.approx(7.5e3)
    assert soc_power_demand(0.40, 0.6, 150e3, 8e3, 4e3) == 8e3
    assert soc_power_demand(0.70, 0.6, 150e3, 8e3, 4e3) == -4e3
    assert regen_fade(0.5, 1.0, 4.5) == 0.0 and regen_fade(10.0, 1.0, 4.5) == 1.0
    assert regen_fade(2.75, 1.0, 4.5) == pytest.approx(0.5)
