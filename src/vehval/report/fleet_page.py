"""The page of ``vehval epa fleet``: rows accounted for, the fleet model against its targets,
errors per procedure and technology, the regression baselines, error histograms and scatters, and the outliers named.

Self-contained HTML (plotly.js inline); figures through :mod:`vehval.report.figures`.
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path
from typing import Any, Sequence

from vehval.io.atomic import write_text_atomic
from vehval.report.document import Block, bullets, figure, h1, h2, para, render_document, table
from vehval.report.figures import FigSpec, histogram_figure, scatter_groups_figure

#: report order of the procedures
PROCEDURES = ("ftp75", "hwfet", "us06")
_PCT = 100.0


def _pc(x: float | None, sign: bool = False) -> str:
    return "-" if x is None else f"{_PCT * x:{'+' if sign else ''}.1f} %"


def _stats_row(name: str, st: dict[str, Any]) -> list[str]:
    if not st.get("n"):
        return [name, "0", "-", "-", "-", "-"]
    return [name, str(st["n"]), _pc(st["median_error"], True), _pc(st["median_abs_error"]),
            _pc(st["share_within_3pct"]), _pc(st["share_within_5pct"])]


_HEAD = ["group", "rows", "median error", "median |error|", "within 3 %", "within 5 %"]


def _accounting(summary: dict[str, Any]) -> list[Block]:
    from vehval.epa.fleet import REASONS

    per = summary["per_list"]
    rows = [[k, str(v["n_rows"]), str(v["n_run"]), str(v["n_not_run"]), str(v["n_failed"])]
            for k, v in per.items()]
    why = [[code, str(n), REASONS.get(code, "")] for code, n in summary["not_run_by_reason"].items()]
    out = [h2("Every row accounted for"),
           table(["list", "rows", "run", "not run", "failed"], rows),
           table(["reason not run", "rows", "meaning"], why)]
    if summary.get("notes"):
        out.append(bullets(summary["notes"]))
    return out


def _verdicts(ver: dict[str, Any] | None, text: str) -> list[Block]:
    """The share of rows with |En| <= 1 and the median |En| per procedure, after ``text``."""
    if not ver:
        return []
    return [para(text), table(["procedure", "rows", "|En| <= 1", "median |En|"],
                              [[p, str(v["n"]), _pc(v["share_consistent"]),
                                f"{v['median_abs_en']:.2f}"] for p, v in ver.items()])]


def _coefficients(summary: dict[str, Any]) -> list[Block]:
    """Which technology coefficients judged which list, and the out-of-sample figures."""
    used = summary.get("coefficients") or []
    if not used:
        return []
    rows = [[c["file"], ", ".join(c["fit_lists"]) or "-", ", ".join(c["lists_judged"]) or "-",
             ", ".join(c["in_sample_lists"]) or "none"] for c in used]
    out = [h2("Technology coefficients and what is in-sample"),
           table(["coefficients", "fitted on", "lists judged", "in-sample lists"], rows)]
    oos = summary.get("out_of_sample") or {}
    err = oos.get("errors") or {}
    if oos.get("n_judged"):
        bias = oos["hwfet_ftp_bias"]
        out += [para(f"Out of sample: {oos['n_judged']} judged rows neither of a list the "
                     "coefficients were fitted on nor a test carried over from one; within 5 %: "
                     f"{_pc(oos['share_within_5pct'])}; "
                     f"HWFET against FTP-75 across cars {_pc(bias['mean'], True)} over "
                     f"{bias['n_cars']} cars."),
                table(_HEAD, [_stats_row(p, err[p]) for p in PROCEDURES if p in err])]
        out += _verdicts(oos.get("verdicts"), "Normalised error En = (model - listed) / "
                         "sqrt(U_model^2 + U_meas^2), k = 2: U_meas from the lists' vehicle-level "
                         "reproducibility of the procedure, U_model from the technology "
                         "coefficients' intervals (efficiencies only).")
    per = [[f"{k} {p}", *_stats_row("", v["errors"][p])[1:]]
           for k, v in summary.get("per_list", {}).items() for p in PROCEDURES
           if p in (v.get("errors") or {})]
    if per:
        out += [para("Per list, every judged row (in-sample rows included):"),
                table(["list and procedure", *_HEAD[1:]], per)]
    if not oos.get("n_judged"):
        out.append(para("Every judged row is of a list the coefficients were fitted on "
                        "(in-sample): run with --cross-year or a file fitted on another list."))
    return out


def _errors(summary: dict[str, Any]) -> list[Block]:
    err = summary["errors"]
    out = [h2("Error per procedure (predicted / measured - 1, judged rows)"),
           table(_HEAD, [_stats_row(p, err[p]) for p in PROCEDURES if p in err])]
    bias = summary["hwfet_ftp_bias"]
    out.append(para(f"HWFET against FTP-75 across cars (mean of (1 + HWFET error) / (1 + FTP "
                    f"error) - 1): {_pc(bias['mean'], True)} over {bias['n_cars']} cars."))
    for grouping, groups in summary["per_technology"].items():
        rows = [_stats_row(f"{g} {p}", d[p]) for g, d in groups.items() for p in PROCEDURES
                if p in d]
        out += [h2(f"Error per {grouping} and procedure"), table(_HEAD, rows)]
    return out


def _baseline(summary: dict[str, Any]) -> list[Block]:
    base = summary.get("baseline") or {}
    if not base:
        return [h2("Regression baselines"), para("Too few judged rows to fit the baselines.")]
    rows = []
    for scheme, procs in base.items():
        for p, d in procs.items():
            rows.append([scheme.replace("_", " "), p, str(d["model"]["n"]),
                         *(f"{_pc(d[k]['median_abs_error'])} / {_pc(d[k]['share_within_5pct'])}"
                           for k in ("model", "baseline", "boosted", "physics_residual")),
                         "physics + residual" if d["residual_better"] else "a baseline",
                         _losses(d.get("loss") or {})])
    return [h2("Physics, the regressions on the list's columns, and physics + learned residual"),
            para("Each cell: median |error| / share within 5 %, on the same rows, "
                 "10-fold cross-validated by test vehicle within a list, or fitted on one "
                 "list to judge another (year to year). Ridge: a log-linear fit on about 20 "
                 "columns (weight, road load, displacement, power, cylinders, N/V, axle ratio, "
                 "gears, transmission, fuel, aspiration). Boosted: gradient-boosted trees on "
                 "the same columns and the make. Physics + learned residual: the same trees "
                 "fitted to the physics model's log error and divided out of its prediction; "
                 "year to year they are fitted on the other list's rows built with the "
                 "judging coefficients. The trees' loss (squared or absolute error) is chosen "
                 "per list and procedure on the list's own within-year folds; year to year, "
                 "the fit takes the choice of the list it is fitted on."),
            table(["scheme", "procedure", "rows", "physics", "ridge", "boosted",
                   "physics + residual", "best", "trees' loss (boosted; residual)"], rows)]


def _losses(loss: dict[str, dict[str, str]]) -> str:
    """``{"boosted": {list: loss}, ...}`` -> ``squared (16tstcar.csv), absolute (19...); ...``."""
    return "; ".join(", ".join(f"{name.split('_')[0]} ({lists})" for lists, name in by.items())
                     or "-" for by in (loss.get("boosted") or {}, loss.get("physics_residual") or {}))


def _fleet_model(summary: dict[str, Any]) -> list[Block]:
    """The physics + learned residual out of sample against the targets."""
    fm = summary.get("fleet_model") or {}
    if not fm.get("n_judged"):
        return []
    err, met, t = fm["errors"], fm["met"], fm["targets"]
    worst = fm.get("worst_group_bias")
    yes = {True: "met", False: "not met"}
    rows = [[f"{p} median |error|", f"{_PCT * st['median_abs_error']:.2f} %",  # 3.01 > 3
             f"<= {_pc(t['median_abs_error'])}",
             yes[met["median_abs_error"][p]]] for p, st in err.items()]
    rows += [["share within 5 %", _pc(fm["share_within_5pct"]),
              f">= {_pc(t['share_within_5pct'])}", yes[met["share_within_5pct"]]],
             ["HWFET / FTP-75 bias", _pc(fm["hwfet_ftp_bias"]["mean"], True),
              f"+-{_pc(t['hwfet_ftp_bias'])}", yes[met["hwfet_ftp_bias"]]],
             ["largest technology group bias", "-" if not worst else
              f"{worst['grouping']} {worst['group']} {worst['procedure']} "
              f"{_pc(worst['median_error'], True)} ({worst['n']} rows)",
              f"+-{_pc(t['group_bias'])}", yes[met["group_bias"]]]]
    out = [h2(f"The fleet model out of sample ({fm['scheme'].replace('_', ' ')}, "
              f"{fm['n_judged']} rows)"),
           para("Physics + learned residual, on rows neither of a list the technology "
                "coefficients were fitted on nor carried over from one."),
           table(["figure", "value", "target", ""], rows),
           table(_HEAD, [_stats_row(p, err[p]) for p in PROCEDURES if p in err])]
    out += _floor(fm.get("floor") or {})
    return out + _verdicts(fm.get("verdicts"), "Normalised error of the fleet model, k = 2: "
                           "U_meas from the lists' vehicle-level reproducibility, U_model from "
                           "the fleet model's own within-year scatter on the other lists "
                           "(robust sigma, the measurement part removed).")


def _floor(floor: dict[str, Any]) -> list[Block]:
    """What a perfect model of the row's columns would reach on these lists."""
    per = floor.get("per_procedure") or {}
    if not per:
        return []
    rows = [[p, str(st["n_groups"]), str(st["n_rows"]), f"{_PCT * st['median_abs_error']:.2f} %",
             _pc(st["share_within_5pct"]), _pc(st["sigma"])] for p, st in per.items()]
    return [para("The data's floor: rows of one procedure, make and the same columns are one "
                 "car to a model of the row; their measured figures still differ (a repeated "
                 "test, another test vehicle, another lab). A perfect model of the columns "
                 "errs by that spread: "
                 f"{_pc(floor['share_within_5pct'])} within 5 % on this procedure mix."),
            table(["procedure", "groups", "rows", "median |error|", "within 5 %",
                   "sigma (one test)"], rows)] + _twins(floor.get("twins") or {})


def _twins(twins: dict[str, Any]) -> list[Block]:
    """The fit lists' near twins against the fleet model, year to year."""
    if not twins:
        return []

    def cells(st: dict[str, Any]) -> list[str]:
        if not st.get("n"):
            return ["0", "-", "-"]
        return [str(st["n"]), f"{_PCT * st['median_abs_error']:.2f} %",
                _pc(st["share_within_5pct"])]

    rows = [[p, *cells(t["twin"]), *cells(t["model"])[1:], *cells(t["model_without_twin"])]
            for p, t in twins.items()]
    return [para("Near twins: a judged row whose fit list holds another test vehicle of the "
                 "same make and technology with every number within 1-3 % is predicted by "
                 "that twin's measured figure alone. Where a twin exists the fleet model is "
                 "read beside it; the rows without one are cars new to the fit list."),
            table(["procedure", "rows with a twin", "twin median |error|", "twin within 5 %",
                   "model median |error|", "model within 5 %", "rows without a twin",
                   "model median |error|", "model within 5 %"], rows)]


def _figures(rows: Sequence[dict[str, Any]], fleet_key: str | None = None) -> list[Block]:
    """Histograms of the physics model's error (and of the fleet model's, ``fleet_key``, on
    its out-of-sample rows) per procedure; the physics' error against three columns."""
    by_proc: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        by_proc[r["procedure"]].append(r)
    hist = histogram_figure({p: [r["error"] for r in by_proc[p]] for p in PROCEDURES
                             if p in by_proc}, xlabel="error [%]", bin_size=1.0, scale=_PCT)
    out = [h2("Figures"), figure(FigSpec("Error histogram per procedure (physics)", hist))]
    if fleet_key:
        fleet = {p: [r[fleet_key] for r in by_proc[p]
                     if r.get(fleet_key) is not None and not r.get("in_sample")]
                 for p in PROCEDURES if p in by_proc}
        if any(fleet.values()):
            out.append(figure(FigSpec(
                "Error histogram per procedure (fleet model: physics + learned residual, "
                "out of sample)",
                histogram_figure({p: v for p, v in fleet.items() if v}, xlabel="error [%]",
                                 bin_size=1.0, scale=_PCT))))
    for col, label, scale in (("specific_power_w_per_l", "rated power per litre [kW/L]", 1e-3),
                              ("mass_kg", "equivalent test weight [kg]", 1.0),
                              ("n_v_ratio", "N/V [rpm/mph]", 1.0)):
        groups = {}
        for p in PROCEDURES:
            pts = [r for r in by_proc.get(p, []) if r.get(col) is not None]
            groups[p] = ([r[col] * scale for r in pts], [_PCT * r["error"] for r in pts],
                         [f"{r['make']} {r['model']} ({r['source']})" for r in pts])
        fig = scatter_groups_figure(groups, xlabel=label, ylabel="error [%]", hlines=(-5.0, 5.0))
        out.append(figure(FigSpec(f"Error against {label.split(' [')[0]}", fig)))
    return out


def _outliers(summary: dict[str, Any], limit: int = 200) -> list[Block]:
    outl = summary["outliers"]
    rows = [[o["row_id"], f"{o['make']} {o['model']}", o["vehicle_id"], o["procedure"],
             o["transmission_class"], o["aspiration"], f"{o['measured_mpg']:.1f}",
             f"{o['predicted_mpg']:.1f}", _pc(o["error"], True), o["why"]] for o in outl[:limit]]
    more = f" (the first {limit} of {len(outl)})" if len(outl) > limit else ""
    return [h2(f"Outliers: {len(outl)} rows{more}"),
            table(["row", "car", "test vehicle", "procedure", "transmission", "engine",
                   "measured mpg", "predicted mpg", "error", "why"], rows)]


def render_fleet_page(records: Sequence[dict[str, Any]], summary: dict[str, Any]) -> str:
    """HTML of the fleet report."""
    from vehval.epa.fleet_summary import judged

    rows = judged(records)
    blocks = [h1(f"Fleet: {', '.join(summary['lists'])}"),
              para(f"{summary['n_rows']} rows: {summary['n_run']} run ({summary['n_judged']} "
                   f"judged), {summary['n_not_run']} not run, {summary['n_failed']} failed; "
                   f"{summary['n_cars']} cars. Every car built from its list row with the "
                   "generic values of vehval epa vehicle, each row on its own procedure, "
                   "weight and road load.")]
    blocks += (_accounting(summary) + _fleet_model(summary) + _coefficients(summary)
               + _errors(summary) + _baseline(summary))
    if rows:
        blocks += _figures(rows, (summary.get("fleet_model") or {}).get("error_key"))
    blocks += _outliers(summary)
    return render_document(blocks, title="Fleet", css="simple.css")


def write_fleet_report(path: str | Path, records: Sequence[dict[str, Any]],
                       summary: dict[str, Any]) -> None:
    """Write the fleet report to ``path`` atomically."""
    write_text_atomic(path, render_fleet_page(records, summary))
