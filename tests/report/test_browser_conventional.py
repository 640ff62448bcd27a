"""A conventional car's report in headless Chromium, from `vehval results` then `vehval report`.

Checked on a virtual conventional test (always) and on the Cruze D3 UDDS 61410013 (skipped
without ../shared): the headline, the conventional energy flow (its sinks add up to the fuel
energy within 0.5 %), no hybrid-only content, display units on three named time plots, and
the file under 3 MB for a 10 Hz test of about 1,400 s. Needs /usr/bin/chromium and the
python playwright package (as test_browser.py); skipped cleanly otherwise.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from helpers.browser import ARGS, CHROMIUM, LOCAL
from helpers.data import REAL

pytestmark = [pytest.mark.browser, pytest.mark.xdist_group("report_browser")]

HERE = Path(__file__).resolve().parent
CRUZE = REAL / "d3_2014_chevrolet_cruze_diesel" / "61410013 Test Data.txt"
CRUZE_TEMPLATE = HERE.parents[0] / "qa" / "templates" / "cruze.yaml"
#: Upper size of the report of a 10 Hz test of about 1,400 s [bytes].
MAX_BYTES = 3_000_000
#: Time-trace panels and the display unit each must show (engineering units, data stay SI).
UNITS = {"Vehicle": "veh_spd [mph]", "Engine": "eng_spd_out [rpm]", "Fuel": "fuel_rate [g/s]"}

_STATE = """() => Array.from(document.querySelectorAll('.vv-fig')).map(el => ({
    caption: (el.closest('figure') && el.closest('figure').querySelector('figcaption')
              ? el.closest('figure').querySelector('figcaption').textContent : ''),
    rendered: el.dataset.rendered === '1',
    type: (el.data && el.data[0]) ? el.data[0].type : '',
    ytitles: Object.keys(el.layout || {}).filter(k => /^yaxis\\d*$/.test(k))
                   .map(k => (el.layout[k].title || {}).text || ''),
    sankey: (el.data && el.data[0] && el.data[0].type === 'sankey')
            ? {labels: el.data[0].node.label, source: Array.from(el.data[0].link.source),
               target: Array.from(el.data[0].link.target),
               value: Array.from(el.data[0].link.value)} : null}))"""


def _run(cli_args: list, tmp: Path) -> Path:
    from vehval.cli import main

    out = tmp / "out"
    assert main(["results", *map(str, cli_args), "-o", str(out)]) == 0
    assert main(["report", str(out), "--no-excel"]) == 0
    return out / "report.html"


def _virtual(tmp: Path) -> Path:
    from vehval.cli import main

    d = tmp / "virtual"
    assert main(["synth", "--vehicle", "cruze_diesel_2014", "--cycle", "udds", "--seed", "3",
                 "-o", str(d)]) == 0
    return _run([next(d.glob("*_d3.txt")), "-t", d / "template.yaml"], tmp)


def _cruze(tmp: Path) -> Path:
    if not CRUZE.is_file():
        pytest.skip("real data not available")
    return _run([CRUZE, "-t", CRUZE_TEMPLATE], tmp)


def _browse(path: Path) -> dict:
    if not Path(CHROMIUM).exists():
        pytest.skip("chromium not installed (run `make browser`)")
    sync_api = pytest.importorskip("playwright.sync_api")
    errors: list[str] = []
    remote: list[str] = []
    with sync_api.sync_playwright() as p:
        try:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        except Exception as exc:  # noqa: BLE001 - a broken browser install is a skip
            pytest.skip(f"chromium does not start: {exc}")
        page = browser.new_page(viewport={"width": 1300, "height": 900})
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.route("**/*", lambda r: r.continue_() if r.request.url.startswith(LOCAL)
                   else (remote.append(r.request.url), r.abort()))
        page.goto(path.as_uri())
        page.evaluate("window.vehvalReport.renderAll()")
        state = page.evaluate(_STATE)
        text = page.evaluate("document.body.innerText")
        headline = page.evaluate("""() => { const dt = Array.from(document.querySelectorAll('dt'))
            .find(d => d.textContent.trim() === 'Headline');
            return dt ? dt.nextElementSibling.textContent : ''; }""")
        fuel_cell = page.evaluate("""() => { const t = document.querySelector('table[data-table="energies"]');
            return t ? t.querySelector('tbody tr td:nth-child(2)').textContent : ''; }""")
        browser.close()
    return {"errors": errors, "remote": remote, "state": state, "text": text,
            "headline": headline, "fuel_mj": float(fuel_cell) if fuel_cell else None}


@pytest.mark.parametrize("source", ["virtual", "cruze"])
def test_conventional_report_in_chromium(source, tmp_path):
    path = _virtual(tmp_path) if source == "virtual" else _cruze(tmp_path)
    size = path.stat().st_size
    print(f"\n{source}: report {size / 1e6:.2f} MB")
    assert size < MAX_BYTES
    b = _browse(path)
    assert b["errors"] == [] and b["remote"] == []
    assert all(s["rendered"] for s in b["state"])
    # the headline of the results section: the UDDS figure in mpg
    assert "udds" in b["headline"] and "mpg" in b["headline"], b["headline"]
    # the conventional energy flow: sinks (nodes with no outgoing link) add up to the fuel
    sankeys = [s["sankey"] for s in b["state"] if s["sankey"]]
    assert len(sankeys) == 1
    sk = sankeys[0]
    fuel = sk["labels"].index("Fuel")
    out_fuel = sum(v for s, v in zip(sk["source"], sk["value"]) if s == fuel)
    leaves = set(sk["target"]) - set(sk["source"])
    sinks = sum(v for t, v in zip(sk["target"], sk["value"]) if t in leaves)
    assert sinks == pytest.approx(out_fuel, rel=0.005)
    assert out_fuel == pytest.approx(b["fuel_mj"], rel=0.005)       # the audit table's fuel
    assert "Wheels (traction)" in sk["labels"] and "Road load" in sk["labels"]
    assert all(s in sk["source"] for s in [sk["labels"].index("Wheels (traction)")])  # connected
    # no hybrid-only content
    for word in ("MG1", "MG2", "Motor map", "Generator map", "Battery current during braking",
                 "SOC window", "Powertrain losses"):
        assert word not in b["text"], word
    # display units on three named plots
    by_caption = {s["caption"]: s["ytitles"] for s in b["state"]}
    for caption, title in UNITS.items():
        assert any(title in t for t in by_caption.get(caption, [])), (caption, by_caption.get(caption))
