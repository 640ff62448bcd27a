"""Regenerate vehval's drive-cycle package data from the regulatory speed tables.

This is a one-off maintenance script, not part of the installed package. It reads the
published speed-time tables (EPA dynamometer driving schedule text files, the NEDC and
WLTC tables as distributed with NREL FASTSim, the Japanese 10-15 and JC08 tables, and the
ADVISOR LA92 table), converts them to SI and writes them in vehval's normalised format::

    # name: udds
    # regulation: US EPA 40 CFR Part 86 Appendix I (UDDS)
    # source: ...
    # units: time s, speed m/s
    time_s,speed_mps
    0,0.000000
    ...

Usage::

    python scripts/make_cycles.py SOURCE_DIR [OUT_DIR]

``SOURCE_DIR`` must contain the sub-folders ``epa/``, ``europe_wltc/``, ``japan/`` and
``advisor/`` (each with a ``SOURCE.txt`` describing where its files come from).
``OUT_DIR`` defaults to ``src/vehval/data/cycles`` of this repository. The script prints
duration, distance and top speed of every cycle and refuses to write anything if a cycle
misses its published duration or distance.
"""

from __future__ import annotations

import argparse
import csv
import io
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

MPH_TO_MPS = 0.44704  # exact: 1 mile = 1609.344 m
KPH_TO_MPS = 1.0 / 3.6


@dataclass
class Table:
    """One cycle ready to be written."""

    name: str
    regulation: str
    source: str
    description: str
    time_s: np.ndarray
    speed_mps: np.ndarray
    expect_duration_s: float | None = None
    expect_distance_km: float | None = None
    tol_km: float = 0.006


def _read_text(path: Path) -> str:
    raw = path.read_bytes()
    if raw[:2] in (b"\xff\xfe", b"\xfe\xff"):
        return raw.decode("utf-16")
    return raw.decode("utf-8-sig")


def read_epa(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Read an EPA ``*col.txt`` schedule: title line, header line, then ``time<TAB>speed``."""
    lines = _read_text(path).splitlines()
    t, v = [], []
    for line in lines[2:]:
        fields = [f for f in line.replace(",", "\t").split("\t") if f.strip()]
        if not fields:
            continue
        t.append(float(fields[0]))
        v.append(float(fields[1]))
    return np.asarray(t), np.asarray(v)


def read_csv_cols(path: Path, tcol: int = 0, vcol: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Read a CSV with one header row (BOM tolerated); return two float columns."""
    rows = list(csv.reader(io.StringIO(_read_text(path))))
    data = [r for r in rows[1:] if r and r[0].strip()]
    return (np.array([float(r[tcol]) for r in data]),
            np.array([float(r[vcol]) for r in data]))


def distance_km(t: np.ndarray, v: np.ndarray) -> float:
    """Trapezoidal distance [km]."""
    return float(np.sum(0.5 * (v[1:] + v[:-1]) * np.diff(t))) / 1000.0


def build(src: Path) -> list[Table]:
    """Build every cycle from the source tables under ``src``."""
    epa, eu, jp, adv = src / "epa", src / "europe_wltc", src / "japan", src / "advisor"
    epa_src = ("US EPA Dynamometer Drive Schedules, file {f} (epa.gov), "
               "speed converted from mph at 0.44704 m/s per mph")
    out: list[Table] = []

    t, v = read_epa(epa / "uddscol.txt")
    out.append(Table("udds", "US EPA 40 CFR Part 86 Appendix I (a) (UDDS, also FTP-72 / LA-4)",
                     epa_src.format(f="uddscol.txt"),
                     "Urban Dynamometer Driving Schedule, light-duty vehicles",
                     t, v * MPH_TO_MPS, 1369, 11.99))

    t, v = read_epa(epa / "ftpcol.txt")
    out.append(Table("ftp75", "US EPA 40 CFR Part 86 Appendix I (a) and 86.137 (FTP-75, bags 1-3)",
                     epa_src.format(f="ftpcol.txt"),
                     "Federal Test Procedure: cold-start UDDS (bags 1 and 2) followed directly by "
                     "the first 505 s of the UDDS (bag 3). The 600 s engine-off hot soak "
                     "between bag 2 and bag 3 is NOT in this trace; insert it if the soak "
                     "matters (thermal or battery studies)",
                     t, v * MPH_TO_MPS, 1874, 17.77))

    t, v = read_epa(epa / "hwycol.txt")
    out.append(Table("hwfet", "US EPA 40 CFR Part 600 Appendix I (HWFET)",
                     epa_src.format(f="hwycol.txt"),
                     "Highway Fuel Economy Test driving schedule",
                     t, v * MPH_TO_MPS, 765, 16.51))

    t, v = read_epa(epa / "us06col.txt")
    out.append(Table("us06", "US EPA 40 CFR Part 86 Appendix I (g) (US06 supplemental FTP)",
                     epa_src.format(f="us06col.txt"),
                     "US06 high-speed, high-acceleration supplemental FTP schedule",
                     t, v * MPH_TO_MPS, 600, 12.89))

    t, v = read_epa(epa / "sc03col.txt")
    out.append(Table("sc03", "US EPA 40 CFR Part 86 Appendix I (h) (SC03 supplemental FTP)",
                     epa_src.format(f="sc03col.txt"),
                     "SC03 air-conditioning supplemental FTP schedule",
                     t, v * MPH_TO_MPS, 600, 5.76))

    t, v = read_csv_cols(adv / "CYC_LA92.csv")  # time_s, speed_mph
    out.append(Table("la92", "California ARB LA92 Unified Cycle (light-duty dynamometer schedule)",
                     "NREL ADVISOR 2003 drive-cycle library, CYC_LA92 (cyc_mph), speed "
                     "converted from mph at 0.44704 m/s per mph",
                     "LA92 (California Unified Cycle), light-duty, 1435 s",
                     t, v * MPH_TO_MPS, 1435, 15.80))

    # NEDC: FASTSim table in m/s, 1180 samples at 0..1179 s. The regulation's cycle lasts
    # 1180 s (4 x 195 s ECE-15 + 400 s EUDC); the table drops the last idle second, so one
    # idle sample is appended at 1180 s (no change in distance).
    t, v = read_csv_cols(eu / "nedc.csv")
    t, v = np.append(t, t[-1] + 1.0), np.append(v, 0.0)
    nedc_reg = ("UNECE Regulation No. 83, Annex 4, Appendix 1 (NEDC; EU Directive 70/220/EEC "
                "as amended by 98/69/EC)")
    nedc_src = "NEDC table distributed with NREL FASTSim (nedc.csv, m/s)"
    out.append(Table("nedc", nedc_reg, nedc_src + "; one idle sample appended at 1180 s",
                     "New European Driving Cycle: 4 x ECE-15 urban + EUDC extra-urban",
                     t, v, 1180, 11.02))
    i_ece = int(np.searchsorted(t, 195.0))
    out.append(Table("ece15", nedc_reg + ", Part One (elementary urban cycle)",
                     nedc_src + ", first 195 s",
                     "ECE-15 elementary urban cycle (one of the four in the NEDC urban part)",
                     t[: i_ece + 1] - t[0], v[: i_ece + 1], 195, 1.013))
    i_eudc = int(np.searchsorted(t, 780.0))
    out.append(Table("eudc", nedc_reg + ", Part Two (extra-urban driving cycle)",
                     nedc_src + ", 780 s to 1180 s",
                     "Extra-Urban Driving Cycle (EUDC), 120 km/h top speed",
                     t[i_eudc:] - t[i_eudc], v[i_eudc:], 400, 6.96))

    # Japan 10-15: EPA table restarts its time for every segment; the official 660 s test is
    # its last 660 rows (3 x 10-mode, idle, 15-mode). They are re-timed 1..660 s and the
    # initial idle sample at 0 s is added.
    t_raw, v_raw = read_epa(epa / "j1015col.txt")
    v = np.concatenate([[0.0], v_raw[-660:]]) * KPH_TO_MPS
    t = np.arange(v.size, dtype=float)
    t_jp, v_jp = read_csv_cols(jp / "JP1015.csv")
    if not (t_jp.size == t.size and np.allclose(v_jp * KPH_TO_MPS, v, atol=1e-9)):
        raise SystemExit("japan1015: EPA j1015col.txt (last 660 rows) and JP1015.csv disagree")
    out.append(Table("japan1015", "Japan MLIT 10-15 mode exhaust emission and fuel economy test cycle",
                     "US EPA Dynamometer Drive Schedules, file j1015col.txt (last 660 rows, "
                     "re-timed), km/h converted to m/s; identical to the 660 s 10-15 table in "
                     "JP1015.csv",
                     "Japanese 10-15 mode: three 10-mode urban segments, idle, one 15-mode "
                     "segment (the preconditioning 15-mode at the start of the EPA file is "
                     "not included)",
                     t, v, 660, 4.16))

    t, v = read_csv_cols(jp / "JC08_1Hz.csv")
    out.append(Table("jc08", "Japan MLIT JC08 mode chassis dynamometer test cycle",
                     "JC08 schedule, 1 Hz, 0.1 km/h resolution (integer-second rows of a "
                     "published 10 Hz table), km/h converted to m/s. Its distance is 8.159 km, "
                     "0.15 % below the 8.171 km usually quoted for JC08",
                     "JC08 mode (replaced 10-15 mode in Japan from 2011)",
                     t, v * KPH_TO_MPS, 1204, 8.171, 0.015))

    t, v = read_csv_cols(eu / "wltc_3b.csv")
    out.append(Table("wltc3b", "UN GTR No. 15 (WLTP), Annex 1, WLTC class 3b",
                     "WLTC class 3b table distributed with NREL FASTSim (wltc_3b.csv, m/s)",
                     "Worldwide harmonized Light vehicles Test Cycle, class 3b (vmax >= 120 km/h): "
                     "low, medium, high and extra-high phases",
                     t, v, 1800, 23.27))
    return out


def render(tb: Table) -> str:
    """Return the CSV text of one cycle in vehval's normalised format."""
    lines = [f"# name: {tb.name}", f"# regulation: {tb.regulation}", f"# source: {tb.source}",
             f"# description: {tb.description}", "# units: time s, speed m/s",
             "time_s,speed_mps"]
    for ti, vi in zip(tb.time_s, tb.speed_mps):
        lines.append(f"{ti:g},{vi:.6f}")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("source_dir", type=Path)
    parser.add_argument("out_dir", type=Path, nargs="?",
                        default=Path(__file__).resolve().parents[1] / "src" / "vehval" / "data"
                        / "cycles")
    args = parser.parse_args(argv)
    tables = build(args.source_dir)
    bad = []
    for tb in tables:
        dur = float(tb.time_s[-1] - tb.time_s[0])
        # Round-trip through the written precision so the check sees the package data.
        v = np.round(tb.speed_mps, 6)
        dist = distance_km(tb.time_s, v)
        ok = ((tb.expect_duration_s is None or abs(dur - tb.expect_duration_s) < 0.5)
              and (tb.expect_distance_km is None or abs(dist - tb.expect_distance_km) <= tb.tol_km)
              and np.all(np.diff(tb.time_s) > 0) and np.all(v >= 0))
        print(f"{tb.name:10s} {dur:7.0f} s {dist:7.3f} km  vmax {v.max() * 3.6:6.1f} km/h "
              f"{'ok' if ok else 'MISMATCH (expected %s s, %s km)' % (tb.expect_duration_s, tb.expect_distance_km)}")
        if not ok:
            bad.append(tb.name)
    if bad:
        print(f"not writing: {', '.join(bad)} miss their published values", file=sys.stderr)
        return 1
    args.out_dir.mkdir(parents=True, exist_ok=True)
    for tb in tables:
        path = args.out_dir / f"{tb.name}.csv"
        tmp = path.with_suffix(".csv.tmp")
        tmp.write_text(render(tb), encoding="utf-8", newline="\n")
        tmp.replace(path)
    print(f"wrote {len(tables)} cycles to {args.out_dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
