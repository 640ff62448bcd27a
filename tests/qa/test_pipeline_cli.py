"""The QA pipeline contract (findings.json) and the `vehval qa` command."""

import json

import numpy as np
import pytest

from vehval.qa.findings import Finding, Kind, Severity, summarise
from vehval.qa.pipeline import run_qa

from .helpers import NR, NS, make_test

TOP_KEYS = {"findings_version", "test", "alignment", "findings", "table2", "table3", "checks",
            "calculations", "selection", "summary", "notes"}


def test_run_qa_document_and_validated_test():
    test = make_test(seed=41, obd_offset_s=1.5)
    before = {s.name: s.time.copy() for s in test}
    res = run_qa(test, {"planetary": {"ring_teeth": NR, "sun_teeth": NS}})
    d = json.loads(json.dumps(res.to_dict()))
    assert set(d) == TOP_KEYS
    assert set(d["test"]) == {"id", "files", "duration_s"}
    assert set(d["calculations"]) >= {"computed", "not_computed", "parameters"}
    assert set(d["summary"]["by_severity"]) == {"info", "warning", "error"}
    assert d["summary"]["by_severity"]["warning"] == 0 and d["summary"]["by_severity"]["error"] == 0
    assert abs(d["alignment"][0]["offset_s"] - 1.5) < 0.05
    # the input test is untouched; the validated one is aligned and has the calc signals
    assert all(np.array_equal(test[n].time, t) for n, t in before.items())
    assert res.validated.meta.offsets_s["obd"] == pytest.approx(d["alignment"][0]["offset_s"])
    assert any(n.endswith("_calc") for n in res.validated.names)
    assert set(d["selection"]["kept"]) <= set(res.validated.names)


def test_finding_roundtrip_and_summary():
    f = Finding("veh_spd_test", Kind.SPIKE, 1.0, 2.0, Severity.WARNING, "x", {"value": float("nan")})
    d = f.to_dict()
    assert d["numbers"]["value"] is None and d["level"] == 1
    assert Finding.from_dict(d).kind == Kind.SPIKE
    s = summarise([f, f])
    assert s["total"] == 2 and s["by_kind"] == {"spike": 2} and s["by_severity"]["error"] == 0


def _write_d3(path, test, names_units):
    """Write the facility signals of a hand test as a D3-style tab file."""
    t = test["veh_spd_test"].time
    cols = [f"{raw}[{unit}]" for raw, (_, unit, _) in names_units.items()]
    lines = ["Time[sec]\t" + "\t".join(cols)]
    data = [t] + [test[n].values * k for n, _, k in names_units.values()]
    for row in np.column_stack(data):
        lines.append("\t".join(f"{x:.4f}" for x in row))
    path.write_text("\n".join(lines) + "\n")


def test_cli_qa_writes_outputs(tmp_path, capsys):
    from vehval.cli import main
    test = make_test(seed=42, obd=())
    f = tmp_path / "t1_d3.txt"
    _write_d3(f, test, {"Dyno_Speed": ("veh_spd_test", "m/s", 1.0),
                        "Dyno_Tractive_Effort": ("veh_frc_in_test", "N", 1.0),
                        "Engine_Speed": ("eng_spd_out_test", "rpm", 60 / (2 * np.pi)),
                        "Bty_Curr": ("veh_spd_test", "A", 0.0)})
    tpl = tmp_path / "t.yaml"
    tpl.write_text(
        "template_version: 1\nconstants: {test_mass_kg: 1295, road_load_a_n: 88.6, "
        "road_load_b_n_per_mps: 0.14, road_load_c_n_per_mps2: 0.36}\nfiles:\n"
        "  - match: '*_d3.txt'\n    source: dyno\n    format: d3\n    time: {column: Time, unit: s}\n"
        "    channels:\n      Dyno_Speed: {name: veh_spd_test, unit: m/s}\n"
        "      Dyno_Tractive_Effort: {name: veh_frc_in_test, unit: N}\n"
        "      Engine_Speed: {name: eng_spd_out_test, unit: rpm}\n"
        "      Bty_Curr: {name: ess_curr_test, unit: A}\n")
    out = tmp_path / "out"
    rc = main(["qa", str(f), "-t", str(tpl), "-o", str(out), "--json"])
    assert rc == 0
    d = json.loads((out / "findings.json").read_text())
    printed = json.loads(capsys.readouterr().out)
    # --json is a public contract: findings.json's keys, plus outdir and files
    for key in ("test", "alignment", "findings", "table2", "table3", "calculations",
                "selection", "summary"):
        assert printed[key] == d[key], key
    assert printed["files"][:1] == ["findings.json"]
    assert d["test"]["id"] and d["summary"]["by_kind"].get("all_zero") == 1
    assert (out / "validated.parquet").is_file()
    from vehval.io.template import load_template
    final = load_template(out / "template_final.yaml")
    assert list(final.selection.drop) == ["ess_curr_test"]
    assert final.selection.drop["ess_curr_test"].startswith("all_zero")
    from vehval.io.parquet import read_test
    assert "veh_frc_in_calc" in read_test(out / "validated.parquet")
    # a bad template is one clear error line and exit code 2, and no output directory
    bad = tmp_path / "bad.yaml"
    bad.write_text("template_version: 1\nfiles: []\n")
    assert main(["qa", str(f), "-t", str(bad), "-o", str(tmp_path / "o2")]) == 2
    assert not (tmp_path / "o2").exists()


def test_cli_qa_counts_read_as_english(tmp_path, capsys):
    """The count line says '1 finding (1 error, 0 warnings, ...)', never '1 findings'."""
    import re

    from vehval.cli import main
    test = make_test(seed=42, obd=())
    f = tmp_path / "t1_d3.txt"
    _write_d3(f, test, {"Dyno_Speed": ("veh_spd_test", "m/s", 1.0),
                        "Bty_Curr": ("veh_spd_test", "A", 0.0)})
    tpl = tmp_path / "t.yaml"
    tpl.write_text(
        "template_version: 1\nfiles:\n"
        "  - match: '*_d3.txt'\n    source: dyno\n    format: d3\n    time: {column: Time, unit: s}\n"
        "    channels:\n      Dyno_Speed: {name: veh_spd_test, unit: m/s}\n"
        "      Bty_Curr: {name: ess_curr_test, unit: A}\n")
    assert main(["qa", str(f), "-t", str(tpl), "-o", str(tmp_path / "out")]) in (0, 4)
    out = capsys.readouterr().out
    doc = json.loads((tmp_path / "out" / "findings.json").read_text())
    n = doc["summary"]["total"]
    line = next(ln for ln in out.splitlines() if re.search(r": \d+ finding", ln))
    assert re.search(rf": {n} finding{'' if n == 1 else 's'} \(", line), line
    for word in ("error", "warning"):
        k = int(re.search(rf"(\d+) {word}", line).group(1))
        assert f"{k} {word}{'' if k == 1 else 's'}" in line, line


def test_cli_qa_says_when_a_repeated_finding_occurs(tmp_path, capsys):
    """Two dropouts of an OBD logger (every PID reads 0 for one sample) give the same range
    sentence twice: the screen adds each one's time, so the two lines can be told apart."""
    from vehval.cli import main

    n = 300
    pres = np.full(n, 101.3)
    pres[[100, 200]] = 0.0
    rows = ["Time,Baro"] + [f"{i:.1f},{p:.1f}" for i, p in enumerate(pres)]
    (tmp_path / "log.csv").write_text("\n".join(rows) + "\n")
    (tmp_path / "t.yaml").write_text(
        "template_version: 1\nfiles:\n  - source: obd\n    format: csv\n"
        "    time: {column: Time, unit: s}\n    channels:\n"
        "      Baro: {name: amb_pres_test, unit: kPa}\n")
    main(["qa", str(tmp_path / "log.csv"), "-t", str(tmp_path / "t.yaml"), "-o",
          str(tmp_path / "out")])
    lines = [ln for ln in capsys.readouterr().out.splitlines() if " range " in ln]
    assert len(lines) == 2, lines
    assert lines[0].endswith("(at 100.0 s)") and lines[1].endswith("(at 200.0 s)")
