"""`vehval simulate` (forward-looking simulation of a vehicle over a cycle) and
`vehval vehicle list|show`."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from vehval.cli.app import app
from vehval.cli.options import bounded, output_dir

vehicle_app = typer.Typer(help="Vehicle parameter files.", no_args_is_help=True)
app.add_typer(vehicle_app, name="vehicle")

SUMMARY_KEYS = ("fuel_mass_kg", "distance_m", "fuel_economy_mpg", "fuel_consumption_l_per_100km",
                "soc_initial", "soc_final", "fuel_economy_soc_corrected_mpg",
                "engine_on_fraction", "engine_starts", "trace_max_miss_mps")


def _write_outputs(result, outdir: Path, audit: dict | None = None) -> list[str]:
    from vehval.io.atomic import atomic_dir
    from vehval.jsonsafe import clean

    written = []
    with atomic_dir(outdir) as stage:
        (stage / "summary.json").write_text(
            json.dumps(clean(result.summary), indent=2, sort_keys=True), encoding="utf-8")
        written.append("summary.json")
        if audit is not None:
            from vehval.sim.audit import audit_lines

            (stage / "audit.json").write_text(json.dumps(audit, indent=2), encoding="utf-8")
            s = result.summary
            head = [f"# Energy audit: {s['vehicle']} on {s['cycle']} (dt = {s['dt_s']:g} s)", "",
                    "```"]
            (stage / "audit.md").write_text("\n".join(head + audit_lines(audit) + ["```", ""]),
                                            encoding="utf-8")
            written += ["audit.json", "audit.md"]
        from vehval.io.parquet import write_test

        write_test(result.test, stage / "signals.parquet")
        written.append("signals.parquet")
    return written


@app.command("simulate")
def simulate_cmd(
    vehicle: str = typer.Option("prius_2004", "--vehicle", help="Vehicle name or YAML path."),
    cycle: str = typer.Option("udds", "--cycle", help="Cycle name or file (see `vehval cycles`)."),
    dt: float = typer.Option(0.1, "--dt", callback=bounded("dt"), help="Time step [s], in [0.001, 1]."),
    soc_initial: Optional[float] = typer.Option(None, "--soc-initial", callback=bounded("soc"),
                                                help="Initial SOC [-] (default: SOC target)."),
    charge_balance: bool = typer.Option(False, "--charge-balance",
                                        help="Iterate the initial SOC until SOC end = start."),
    cold_start: bool = typer.Option(False, "--cold-start", help="Start with a cold engine: "
                                    "the vehicle's cold-start model applies (warm-up fuel; a "
                                    "hybrid's engine-on hold)."),
    set_: list[str] = typer.Option([], "--set", help="Override a parameter: block.key=value "
                                   "(repeatable), e.g. controller.soc_target=0.55."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as one JSON object."),
    audit: bool = typer.Option(False, "--audit", help="Energy audit: where fuel and battery "
                               "energy went (JSON key 'audit', audit.json/audit.md with -o)."),
    outdir: Optional[Path] = typer.Option(None, "-o", "--output", callback=output_dir,
                                          help="Directory for summary.json and the signals."),
) -> None:
    """Simulate a vehicle over a drive cycle (forward-looking, state-machine controller)."""
    from vehval.cli.options import parse_assignments
    from vehval.errors import ConfigError
    from vehval.io.paths import check_outputs, vehicle_path
    from vehval.jsonsafe import clean
    from vehval.sim.simulate import simulate

    if outdir is not None:
        check_outputs(outdir=outdir, inputs=[vehicle_path(vehicle), vehicle_path(cycle)],
                      writes=["summary.json", "signals.parquet"])
    overrides = parse_assignments(set_, "--set", "controller.soc_target=0.55")
    for key, val in overrides.items():
        if isinstance(val, bool) or not isinstance(val, (int, float)):
            raise ConfigError(f"--set '{key}={val}': value must be a number")
    res = simulate(vehicle, cycle, dt=dt, soc_initial=soc_initial,
                   charge_balance=charge_balance, cold_start=cold_start, **overrides)
    s = res.summary
    for warning in s.get("warnings") or []:
        typer.echo(f"vehval: warning: {warning}", err=True)
    if cold_start:
        _note_without_cold_model(vehicle, overrides)
    aud = None
    if audit:
        from vehval.sim.audit import energy_audit

        if "gen_loss_j" not in s:
            raise ConfigError(f"--audit: vehicle '{s.get('vehicle', vehicle)}' has no energy "
                              "audit (power-split vehicles only)")
        aud = energy_audit(s)
    written = _write_outputs(res, outdir, aud) if outdir is not None else []
    if as_json:
        keys = [k for k in SUMMARY_KEYS if k in s] + [k for k in s if k not in SUMMARY_KEYS]
        doc = clean({k: s[k] for k in keys})
        if aud is not None:
            doc["audit"] = aud
        typer.echo(json.dumps(doc))
        return
    _screen(s, aud)
    if written and outdir is not None:
        typer.echo(f"  wrote {', '.join(str(outdir / w) for w in written)}")


def _screen(s: dict, aud: dict | None) -> None:
    """The simulation on screen, per architecture (the JSON has every figure)."""
    from vehval.constants import MPH_M_PER_S
    from vehval.display import format_value, fuel_text

    miss = format_value(s["trace_max_miss_mps"], "m/s", digits=3)
    # the regulatory trace tolerance is ±2 mph, shown in the display unit of speed
    band = f"outside ±{format_value(2.0 * MPH_M_PER_S, 'm/s', digits=2)} / ±1 s"
    typer.echo(f"{s['vehicle']} on {s['cycle']} (dt = {s['dt_s']:g} s)")
    typer.echo(f"  distance            {format_value(s['distance_m'], 'm')}")
    from vehval.architectures import stages

    if not stages(s.get("architecture")).burns_fuel:
        _electric_lines(s, miss, band)
        return
    typer.echo(f"  fuel                {s['fuel_mass_kg'] * 1000:.1f} g")
    typer.echo(f"  fuel economy        "
               f"{fuel_text(s['fuel_economy_mpg'], s['fuel_consumption_l_per_100km'])}")
    if not stages(s.get("architecture")).has_battery:
        typer.echo(f"  gear shifts         {s['gear_shifts']:8d}")
        typer.echo(f"  fuel cut            {s['fuel_cut_time_s']:8.1f} s, idle "
                   f"{s['idle_time_s']:.1f} s, converter open {s['unlocked_time_s']:.1f} s")
        typer.echo(f"  trace max miss      {miss} ({band})")
        typer.echo(f"  energy balance      {s['energy_balance_rel']:.1e} (relative residual)")
        return
    typer.echo("  SOC-corrected       " + fuel_text(s["fuel_economy_soc_corrected_mpg"],
                                                   s.get("fuel_consumption_soc_corrected_l_per_100km")))
    _soc_lines(s)
    typer.echo(f"  engine on           {100 * s['engine_on_fraction']:.1f} % "
               f"({s['engine_starts']} starts)")
    typer.echo(f"  trace max miss      {miss} ({band})")
    typer.echo(f"  energy balance      {s['energy_balance_rel']:.1e} (relative residual)")
    if aud is not None:
        from vehval.sim.audit import audit_lines

        typer.echo("energy audit:")
        for line in audit_lines(aud):
            typer.echo(f"  {line}")


@vehicle_app.command("list")
def vehicle_list_cmd() -> None:
    """List the vehicles shipped with vehval."""
    from vehval.vehicle import list_vehicles

    for name in list_vehicles():
        typer.echo(name)


@vehicle_app.command("show")
def vehicle_show_cmd(
    name: str = typer.Argument(..., help="Vehicle name or YAML path."),
    sources: bool = typer.Option(False, "--sources", help="Show the source of each parameter."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
) -> None:
    """Show a vehicle's scalar parameters (maps are summarised)."""
    from vehval.vehicle import load_vehicle

    veh = load_vehicle(name)
    params = veh.parameters()
    src = veh.sources()
    if as_json:
        typer.echo(json.dumps({"name": veh.name, "file": veh.file, "parameters": params,
                               "sources": src}))
        return
    typer.echo(f"{veh.name}: {veh.description}")
    for key, val in params.items():
        line = f"  {key:48s} {val:g}"
        if sources:
            line += f"   [{src.get(key, '')}]"
        typer.echo(line)


def _note_without_cold_model(vehicle: str, overrides: dict) -> None:
    """Say so when ``--cold-start`` has no effect: the car has no cold-start model."""
    from vehval.sim.simulate import architecture
    from vehval.vehicle import load_vehicle

    veh = load_vehicle(vehicle)
    if not architecture(veh).cold_start_model(veh.with_overrides(overrides)
                                              if overrides else veh):
        typer.echo(f"note: {veh.name} has no cold-start model (no warm-up fuel, no cold "
                   "engine-on time): --cold-start runs as a hot start", err=True)


def _soc_lines(s: dict) -> None:
    """The SOC line, and on stderr a charge balance asked for and not reached."""
    typer.echo(f"  SOC                 {100 * s['soc_initial']:.1f} % -> "
               f"{100 * s['soc_final']:.1f} %")
    if s.get("charge_balance_iterations") and not s.get("charge_balanced"):
        from vehval.display import percent
        from vehval.sim.simulate import CHARGE_BALANCE_TOL

        typer.echo(f"  charge balance      NOT reached in {s['charge_balance_iterations']} runs "
                   f"(SOC change {percent(s['soc_delta'])}, tolerance "
                   f"±{percent(CHARGE_BALANCE_TOL)}): the closest run is shown; read the "
                   "SOC-corrected figure", err=True)


def _electric_lines(s: dict, miss: str, band: str) -> None:
    """The screen summary of a car that burns no fuel: SAE J1634 AC consumption (per 100 mi
    or 100 km as ``--units`` reads), MPGe, the battery's DC energy and regeneration, SOC."""
    from vehval.display import system

    per = (f"{s['ac_kwh_per_100mi']:.2f} kWh/100 mi ({s['ac_kwh_per_100km']:.2f} kWh/100 km)"
           if system() == "us" else
           f"{s['ac_kwh_per_100km']:.2f} kWh/100 km ({s['ac_kwh_per_100mi']:.2f} kWh/100 mi)")
    typer.echo(f"  AC consumption      {per}, charger {s['charger_efficiency']:g}")
    typer.echo(f"  MPGe                {s['mpge']:.1f}")
    typer.echo(f"  battery DC          {s['dc_energy_kwh']:.3f} kWh net, regeneration "
               f"{s['regen_energy_kwh']:.3f} kWh")
    _soc_lines(s)
    typer.echo(f"  trace max miss      {miss} ({band})")
    typer.echo(f"  energy balance      {s['energy_balance_rel']:.1e} (relative residual)")
