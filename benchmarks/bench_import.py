"""Import speed: ``import_test`` of a 10 Hz, 1,500 s, 60-channel D3 file against plain pyarrow.

The baseline is ``pyarrow.csv.read_csv`` of the same file in the same run (tab delimiter, type
inference, no checks, no units, no renaming). ``import_test`` adds the byte checks (encoding,
NUL bytes, stray header bytes, truncated line), the template, SI conversion of every channel
and the time checks. Target: less than 2x the baseline. Run standalone with
``python -m benchmarks.bench_import``.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

from benchmarks.common import best_of, make_d3_file, row
from vehval.io.importer import import_test
from vehval.io.parquet import write_test
from vehval.io.propose import propose_template
from vehval.io.readers import read_raw

DURATION_S = 1500.0
RATE_HZ = 10.0
N_CHANNELS = 60


def _pyarrow_read(path: Path) -> pa.Table:
    return pacsv.read_csv(path, parse_options=pacsv.ParseOptions(delimiter="\t"))


def _name_daq_channels(template) -> None:
    """Hand edit: give the generic DAQ channels standard names so that (nearly) every column
    is converted, as in a real template."""
    from vehval.io.template import ChannelSpec

    chans = template.files[0].channels
    for key in list(chans):
        k = key.rsplit("_", 1)[-1]
        if key.startswith("DAQ_Temp_"):
            chans[key] = ChannelSpec(name=f"amb_temp_t{k}_test", unit="degC")
        elif key.startswith("DAQ_Volt_"):
            chans[key] = ChannelSpec(name=f"aux_volt_v{k}_test", unit="V")


def run() -> list[dict]:
    """Time the import pipeline against pyarrow; rows for the benchmark harness."""
    rows: list[dict] = []
    with tempfile.TemporaryDirectory() as tmp:
        path = make_d3_file(Path(tmp) / "bench Test Data.txt", duration_s=DURATION_S,
                            rate_hz=RATE_HZ, n_channels=N_CHANNELS)
        size_mb = path.stat().st_size / 1e6
        template, _ = propose_template([path])
        template.constants.fuel_density_kg_per_m3 = 745.0
        _name_daq_channels(template)
        n_sig = len(import_test([path], template))
        n_del = sum(ch.delete for ch in template.files[0].channels.values())
        desc = (f"{int(DURATION_S * RATE_HZ)} rows x {N_CHANNELS} channels, {size_mb:.1f} MB; "
                f"{n_sig} signals imported to SI, {n_del} deleted")

        t_base = best_of(lambda: _pyarrow_read(path), n=3)
        t_imp = best_of(lambda: import_test([path], template), n=3)
        rows.append(row("import_test_d3_1500s_60ch", t_imp, "s", baseline=t_base, target=2.0,
                        note=f"{desc}; baseline pyarrow.csv.read_csv of the same file"))
        t_raw = best_of(lambda: read_raw(path), n=3)
        rows.append(row("read_raw_d3_1500s_60ch", t_raw, "s", baseline=t_base, target=1.5,
                        note="reader only (byte checks + pyarrow parse); same baseline"))

        test = import_test([path], template)
        out = Path(tmp) / "test.parquet"
        table = _pyarrow_read(path)
        t_pq_base = best_of(lambda: pq.write_table(table, Path(tmp) / "plain.parquet",
                                                   compression="zstd"), n=3)
        t_pq = best_of(lambda: write_test(test, out), n=3)
        rows.append(row("write_test_parquet_60ch", t_pq, "s", baseline=t_pq_base, target=2.0,
                        note="Test -> Parquet with per-field metadata, atomic; baseline "
                             "pyarrow.parquet.write_table of the raw table"))
        t_prop = best_of(lambda: propose_template([path]), n=3)
        rows.append(row("template_init_60ch", t_prop, "s", target=1.0,
                        note="propose_template on the same file (alias + fuzzy matching)"))
    return rows


def main() -> None:
    for r in run():
        ratio = f"{r['ratio']:.2f}x" if r["ratio"] is not None else "-"
        base = f"{r['baseline']:.4f}" if r["baseline"] is not None else "-"
        print(f"{r['name']:30s} {r['value']:.4f} {r['unit']}  baseline {base}  ratio {ratio}  "
              f"target {r['target']}  ({r['note']})")


if __name__ == "__main__":
    main()
