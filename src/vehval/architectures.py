"""What each stage does for each vehicle architecture: one registry.

The simulator has its own registry (:data:`vehval.sim.simulate.ARCHITECTURES`: how to pack,
run and summarise a powertrain). Every later stage chooses by architecture here, once:
the virtual test maker (``synth``), the validation against a test (``validate``: the
simulation on the test's conditions for a hybrid, the fuel prediction of
:mod:`vehval.identify.predict` for a conventional car), the calibration (``calibrate``),
the control-strategy analysis (``analyze``), the identification from dyno tests
(``identify``) and prediction (``predict``), and the family of the results and the
packaged precision (``family``). A stage an architecture does not have is ``None``:
:func:`require` refuses it in one line naming the architectures that have it.

The command line and :mod:`vehval.workflow` dispatch through :func:`stages`; a new
architecture is one entry of :data:`REGISTRY` plus the functions it names.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from vehval.errors import ConfigError

#: The architecture of a vehicle file that does not name one (as the simulator reads it).
DEFAULT = "power_split"


def _synth_power_split(*args: Any, **kw: Any) -> Any:
    from vehval.synth.front import power_split_test

    return power_split_test(*args, **kw)


def _synth_conventional(*args: Any, **kw: Any) -> Any:
    from vehval.synth.front import conventional_test

    return conventional_test(*args, **kw)


def _validate_power_split(run: Any, *, dt: float, window_s: float, smooth_hz: float | None,
                          overrides: dict | None) -> Any:
    """The simulation on the test's own conditions compared with QA's validated test."""
    from vehval.validate import validate_test

    if run.results_outcome is None and run.template is not None:
        run.results()  # the verdicts use the template's declared accuracies
    res = run.results_outcome.results if run.results_outcome is not None else None
    return validate_test(run.validated, run.vehicle, dt=dt, window_s=window_s,
                         smooth_hz=smooth_hz, overrides=overrides, results=res)


def _validate_conventional(run: Any, *, overrides: dict | None, **_: Any) -> Any:
    """The fuel prediction of the imported test (``vehval predict``'s comparison)."""
    from vehval.identify.comparison import predict_comparison

    return predict_comparison(run.vehicle, run.test, overrides)


def _synth_battery_electric(*args: Any, **kw: Any) -> Any:
    from vehval.synth.front import battery_electric_test

    return battery_electric_test(*args, **kw)


def _validate_battery_electric(run: Any, *, dt: float, smooth_hz: float | None,
                               overrides: dict | None, **_: Any) -> Any:
    """The simulation on the test's speed trace, mass and road load against its traces, DC
    energy and SAE J1634 figures; U_model the declared bound of list-row validation."""
    from vehval.epa.bev import MODEL_U_REL, MODEL_U_SOURCE
    from vehval.validate.bev import validate_bev_test

    return validate_bev_test(run, dt=dt, smooth_hz=smooth_hz, overrides=overrides,
                             u_model_rel=MODEL_U_REL, u_model_source=MODEL_U_SOURCE)


def _synth_parallel_hybrid(*args: Any, **kw: Any) -> Any:
    from vehval.synth.front import parallel_hybrid_test

    return parallel_hybrid_test(*args, **kw)


def _validate_parallel_hybrid(run: Any, *, dt: float, overrides: dict | None,
                              **_: Any) -> Any:
    """The simulation on the test's speed trace from its SOC against its traces: engine
    on/off and speed, battery energy, motor torque, gear."""
    from vehval.validate.parallel import validate_parallel_test

    return validate_parallel_test(run, dt=dt, overrides=overrides)


def _analyze_parallel_hybrid(test: Any, vehicle: Any) -> Any:
    from vehval.analysis.parallel import analyze_parallel

    return analyze_parallel(test, vehicle)


def _calibrate_power_split(*args: Any, **kw: Any) -> Any:
    from vehval.validate.calibrate_stage import calibrate_power_split

    return calibrate_power_split(*args, **kw)


def _calibrate_conventional(*args: Any, **kw: Any) -> Any:
    from vehval.identify.calibrate_stage import calibrate_conventional_stage

    return calibrate_conventional_stage(*args, **kw)


def _analyze_power_split(test: Any, vehicle: Any) -> Any:
    from vehval.analysis import analyze

    return analyze(test, vehicle)


def _identify_conventional(*args: Any, **kw: Any) -> Any:
    from vehval.identify.build import identify_conventional

    return identify_conventional(*args, **kw)


def _predict_conventional(*args: Any, **kw: Any) -> Any:
    from vehval.identify.predict import predict_trace

    return predict_trace(*args, **kw)


@dataclass(frozen=True)
class Stages:
    """The stages of one architecture (``None``: the stage does not exist for it).

    Attributes
    ----------
    name : str
        The vehicle file's ``architecture``.
    label : str
        How text names the architecture (``power-split hybrid``).
    family : str
        Family of the results and of the packaged precision (``hybrid``, ``conventional``).
    synth : callable
        ``(veh, vehicle, cycle, seed, faults, out, control, param, force) ->``
        :class:`vehval.synth.front.VirtualTest`.
    validate : callable
        ``(run, dt=, window_s=, smooth_hz=, overrides=)`` -> the comparison of one
        :class:`~vehval.workflow.TestRun` (``to_dict()``, ``payload(figures)``).
    validate_suite : bool
        Whether ``vehval validate`` ranks its tests on the tolerance ladder (the simulation
        on the test's conditions); else ``hint`` says what to use.
    hint : str
        What to use instead of a stage the architecture does not have (and of ``vehval
        validate`` without ``validate_suite``), in every refusal.
    calibrate : callable
        ``(veh, load, **options)`` -> :class:`vehval.validate.calibrate_stage.CalibrationStage`.
    analyze : callable or None
        ``(test, vehicle)`` -> the control-strategy analysis.
    identify, predict : callable or None
        Identification from dyno tests; prediction of a test's fuel.
    """

    name: str
    label: str
    family: str
    hint: str
    validate_suite: bool = False
    synth: Callable[..., Any] | None = None
    validate: Callable[..., Any] | None = None
    calibrate: Callable[..., Any] | None = None
    analyze: Callable[..., Any] | None = None
    identify: Callable[..., Any] | None = None
    predict: Callable[..., Any] | None = None

    @property
    def has_battery(self) -> bool:
        """Whether the powertrain has a traction battery (the simulator's registry)."""
        from vehval.sim.simulate import ARCHITECTURES

        return ARCHITECTURES[self.name].has_battery

    @property
    def burns_fuel(self) -> bool:
        """Whether the powertrain has an engine burning fuel (fuel signals it may have)."""
        from vehval.vehicle.definition import absent_categories

        return "fuel" not in absent_categories(self.name)

    @property
    def is_hybrid(self) -> bool:
        """A hybrid: a traction battery and a fuel (what :func:`vehval.test.is_hybrid`
        decides from a vehicle file's blocks)."""
        return self.has_battery and self.burns_fuel


#: Architecture name -> its stages.
REGISTRY: dict[str, Stages] = {
    "power_split": Stages(
        name="power_split", label="power-split hybrid", family="hybrid",
        synth=_synth_power_split, validate=_validate_power_split, validate_suite=True,
        hint="for a hybrid use vehval validate (the simulation on the test's conditions) "
             "or vehval calibrate",
        calibrate=_calibrate_power_split, analyze=_analyze_power_split),
    "conventional": Stages(
        name="conventional", label="conventional car", family="conventional",
        synth=_synth_conventional, validate=_validate_conventional, validate_suite=False,
        hint="for a conventional car use vehval validate or vehval predict (fuel per "
             "phase, judged test by test) or vehval calibrate",
        calibrate=_calibrate_conventional, identify=_identify_conventional,
        predict=_predict_conventional),
    "parallel_hybrid": Stages(
        name="parallel_hybrid", label="parallel hybrid", family="hybrid",
        synth=_synth_parallel_hybrid, validate=_validate_parallel_hybrid,
        validate_suite=False, analyze=_analyze_parallel_hybrid,
        hint="for a parallel hybrid use vehval analyze (assist / regen / engine-stop rules) "
             "or vehval validate (engine on/off and speed, battery energy, motor torque, "
             "judged test by test)"),
    "battery_electric": Stages(
        name="battery_electric", label="battery-electric car", family="electric",
        synth=_synth_battery_electric, validate=_validate_battery_electric,
        validate_suite=False,
        hint="for a battery-electric car use vehval results (SAE J1634 energy and MPGe), "
             "vehval epa validate on the list's electricity rows, or vehval validate "
             "(traces, DC energy and J1634 figures, judged test by test)"),
}

#: Text of each stage in a refusal.
STAGE_TEXT = {"synth": "a virtual test", "validate": "validation",
              "calibrate": "calibration", "analyze": "the control-strategy analysis",
              "identify": "identification from dyno data", "predict": "prediction of fuel"}


def name_of(vehicle: Any) -> str:
    """The architecture name of a vehicle, a name, or None (the default)."""
    if vehicle is None:
        return DEFAULT
    if isinstance(vehicle, str):
        return vehicle
    return str(getattr(vehicle, "architecture", DEFAULT))


def stages(vehicle: Any) -> Stages:
    """The stages of ``vehicle``'s architecture (a vehicle, an architecture name, or None
    for the default); ConfigError naming an unknown one and the known ones."""
    name = name_of(vehicle)
    try:
        return REGISTRY[name]
    except KeyError:
        where = getattr(vehicle, "file", None) or getattr(vehicle, "name", None)
        raise ConfigError(f"{where + ': ' if where else ''}no stages for architecture "
                          f"{name!r} (known: {', '.join(REGISTRY)})") from None


def having(stage: str) -> list[str]:
    """The architectures that have ``stage``."""
    return [n for n, s in REGISTRY.items() if getattr(s, stage) is not None]


def require(vehicle: Any, stage: str) -> Callable[..., Any]:
    """The function of ``stage`` for ``vehicle``'s architecture; ConfigError in one line
    when that architecture has none (naming the ones that have it)."""
    fn = getattr(stages(vehicle), stage)
    if fn is None:
        name = name_of(vehicle)
        who = f"vehicle '{vehicle.name}' is '{name}': " if hasattr(vehicle, "name") else ""
        hint = stages(vehicle).hint
        raise ConfigError(f"{who}{STAGE_TEXT[stage]} is not available for '{name}' (it is "
                          f"for: {', '.join(repr(n) for n in having(stage))})"
                          + (f"; {hint}" if hint else ""))
    return fn
