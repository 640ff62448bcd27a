"""EPA validation report: the per-test / per-bag table and a predicted-vs-measured plot.

One self-contained HTML file (inline SVG, no script), plus ``epa_validation.json`` (the
:meth:`~vehval.epa.validation.EpaValidation.to_dict` contract) and ``epa_validation.csv``.
"""

from __future__ import annotations

import csv
import html
import io
from pathlib import Path

from vehval import jsonsafe
from vehval.epa.consistency import group_mismatches
from vehval.epa.validation import TOLERANCE, EpaValidation
from vehval.report.safety import CSP_META

_COLORS = {"ftp75": "#1f77b4", "hwfet": "#2ca02c", "us06": "#d62728"}


def table_rows(val: EpaValidation) -> list[dict]:
    """One dict per compared figure (the CSV rows)."""
    return [c.to_dict() for c in val.comparisons]


def scatter_svg(val: EpaValidation, size: int = 420) -> str:
    """Predicted vs measured fuel economy [mpg] as an SVG scatter with the 1:1 and ±5 % lines.

    Judged figures are filled circles, figures not judged (cold start without a cold-start
    model, or a test whose listed figures disagree) open circles.
    """
    pts = [(c.measured_mpg, c.predicted_mpg, c) for c in val.comparisons]
    if not pts:
        return "<p>No figure to plot.</p>"
    lo = min(min(p[0], p[1]) for p in pts) * 0.9
    hi = max(max(p[0], p[1]) for p in pts) * 1.05
    m = 50

    def sx(x):
        return m + (x - lo) / (hi - lo) * (size - 2 * m)

    def sy(y):
        return size - m - (y - lo) / (hi - lo) * (size - 2 * m)

    out = [(f'<svg xmlns="http://www.w3.org/2000/svg" width="{size}" height="{size}" '
            'font-family="sans-serif" font-size="11">'),
           (f'<rect x="{m}" y="{m}" width="{size - 2 * m}" height="{size - 2 * m}" '
            'fill="none" stroke="#888"/>')]
    # the 1:1 and tolerance lines, clipped to the plot area (the ±5 % lines leave it)
    out.append(f'<defs><clipPath id="epa-plot-area"><rect x="{m}" y="{m}" '
               f'width="{size - 2 * m}" height="{size - 2 * m}"/></clipPath></defs>'
               '<g clip-path="url(#epa-plot-area)">')
    for k, dash in ((1.0, ""), (1 + TOLERANCE, "4,3"), (1 - TOLERANCE, "4,3")):
        out.append(f'<line x1="{sx(lo):.1f}" y1="{sy(lo * k):.1f}" x2="{sx(hi):.1f}" '
                   f'y2="{sy(hi * k):.1f}" stroke="#999" stroke-dasharray="{dash}"/>')
    out.append("</g>")
    step = 10 if hi - lo < 120 else 20
    v = (int(lo) // step + 1) * step
    while v < hi:
        out.append(f'<text x="{sx(v):.1f}" y="{size - m + 14}" text-anchor="middle">{v}</text>')
        out.append(f'<text x="{m - 6}" y="{sy(v) + 4:.1f}" text-anchor="end">{v}</text>')
        v += step
    for x, y, c in pts:
        col = _COLORS.get(c.procedure, "#555")
        fill = col if c.judged else "none"
        title = html.escape(f"{c.test} {c.procedure} {c.item}: predicted {c.predicted_mpg:.1f}, "
                            f"measured {c.measured_mpg:.1f} mpg ({100 * c.error:+.1f} %)")
        out.append(f'<circle cx="{sx(x):.1f}" cy="{sy(y):.1f}" r="4" fill="{fill}" '
                   f'stroke="{col}"><title>{title}</title></circle>')
    out.append(f'<text x="{size / 2}" y="{size - 12}" text-anchor="middle">measured '
               '[mpg]</text>')
    out.append(f'<text x="14" y="{size / 2}" text-anchor="middle" transform="rotate(-90 14 '
               f'{size / 2})">predicted [mpg]</text>')
    legend = [("FTP-75", "ftp75"), ("HWFET", "hwfet"), ("US06", "us06")]
    for i, (label, key) in enumerate(legend):
        out.append(f'<circle cx="{m + 10}" cy="{m + 14 + 14 * i}" r="4" '
                   f'fill="{_COLORS[key]}"/><text x="{m + 18}" y="{m + 18 + 14 * i}">'
                   f'{label}</text>')
    out.append(f'<text x="{m + 10}" y="{m + 60}">open: not judged (cold start, doubtful list)'
               '</text>')
    out.append("</svg>")
    return "".join(out)


def share_text(x: float | None) -> str:
    """A battery share [-] as signed percent with one decimal ("-" without a battery)."""
    return "-" if x is None else f"{round(100 * x, 1) + 0.0:+.1f}"  # + 0.0: no "-0.0"


def render_html(val: EpaValidation) -> str:
    """The whole report page."""
    st = val.stats()
    corr = st["spread_correlation"]
    rows = []
    for c in val.comparisons:
        ok = abs(c.error) <= TOLERANCE
        cls = "" if not c.judged else (' class="ok"' if ok else ' class="bad"')
        rows.append(f"<tr{cls}><td>{html.escape(c.test)}</td><td>{c.originator}</td>"
                    f"<td>{c.procedure}</td><td>{html.escape(c.item)}</td>"
                    f"<td>{c.predicted_mpg:.1f}</td><td>{c.measured_mpg:.1f}</td>"
                    f"<td>{100 * c.error:+.1f}</td><td>{share_text(c.battery_share)}</td>"
                    f"<td>{'yes' if c.judged else 'no'}</td>"
                    f"<td>{html.escape(c.note)}</td></tr>")
    r_kind = corr["per_kind"]
    kinds = "".join(
        f"<tr><td>{html.escape(k)}</td><td>{v['n']}</td><td>{v['n_within_tolerance']}</td>"
        f"<td>{100 * v['mean_error']:+.1f}</td><td>{100 * v['mean_abs_error']:.1f}</td>"
        f"<td>{100 * v['max_abs_error']:.1f}</td>"
        f"<td>{'-' if r_kind.get(k) is None else f'{r_kind[k]:.3f}'}</td></tr>"
        for k, v in st["per_kind"].items())
    skipped = "".join(f"<li>{html.escape(s['test'])} ({html.escape(s['description'])}): "
                      f"{html.escape(s['reason'])}</li>" for s in val.skipped)
    pooled = corr["pooled"]
    groups = group_mismatches((p.test.label, p.vehicle_check) for p in val.predictions)
    mismatch = "".join(
        f"<p class=\"warn\">&#9888; {len(labels)} test(s) ({html.escape(', '.join(labels))}): "
        f"{html.escape(note)}. Their errors judge the vehicle file on a car it may not "
        "describe.</p>" for note, labels in groups.items())
    return f"""<!DOCTYPE html><html><head><meta charset="utf-8">{CSP_META}
<title>vehval EPA validation: {html.escape(val.vehicle)}</title>
<style>body{{font-family:sans-serif;margin:2em}}table{{border-collapse:collapse}}
td,th{{border:1px solid #ccc;padding:2px 6px;text-align:right}}td:nth-child(-n+4){{text-align:left}}
tr.ok td{{background:#e8f6e8}}tr.bad td{{background:#fbe9e9}}
p.warn{{background:#fff4d6;padding:4px 8px}}</style></head><body>
<h1>EPA certification tests: {html.escape(val.vehicle)}</h1>
<p>{st['n_tests_simulated']} tests simulated, {st['n_tests_skipped']} skipped;
{st['n_within_tolerance']} of {st['n_judged']} judged figures within
{100 * TOLERANCE:.0f} % ({st['n_within_3pct']} within 3 %); mean error
{100 * (st['mean_error'] or 0):+.1f} %, mean |error| {100 * (st['mean_abs_error'] or 0):.1f} %.
Correlation of predicted and measured judged figures: r = {'-' if pooled is None
                                                           else f'{pooled:.3f}'}.</p>
{mismatch}
{scatter_svg(val)}
<h2>By figure</h2>
<table><tr><th>figure</th><th>judged</th><th>within {100 * TOLERANCE:.0f} %</th>
<th>mean error %</th><th>mean |error| %</th><th>largest |error| %</th><th>r</th></tr>
{kinds}</table>
<h2>Every figure</h2>
<table><tr><th>test</th><th>by</th><th>procedure</th><th>figure</th><th>predicted mpg</th>
<th>measured mpg</th><th>error %</th><th>battery %</th><th>judged</th><th>note</th></tr>
{''.join(rows)}</table>
<p>battery %: in the model, the battery's chemical energy spent in the figure over the fuel
energy burnt in it (&gt; 0: the battery helped). SAE J1711 holds the whole test to a net
energy change within 1 % of the fuel energy; a single bag is not balanced, so a bag with a
large share depends on the charge the bag before it left, which the lab does not report.
Within each UDDS of an FTP-75 (bags 1 + 2, bags 3 + 4) the charge one phase stores the next
spends: their share is near 0.</p>
<h2>Skipped tests</h2><ul>{skipped or '<li>none</li>'}</ul>
</body></html>"""


def write_epa_report(val: EpaValidation, outdir: str | Path) -> list[str]:
    """Write report.html, epa_validation.json and epa_validation.csv atomically."""
    from vehval.io.atomic import atomic_dir

    rows = table_rows(val)
    buf = io.StringIO()
    if rows:
        w = csv.DictWriter(buf, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    with atomic_dir(Path(outdir)) as stage:
        (stage / "report.html").write_text(render_html(val), encoding="utf-8")
        (stage / "epa_validation.json").write_text(jsonsafe.dumps(val),
                                                   encoding="utf-8")
        (stage / "epa_validation.csv").write_text(buf.getvalue(), encoding="utf-8")
    return ["report.html", "epa_validation.json", "epa_validation.csv"]
