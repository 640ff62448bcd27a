"""A test given twice (the same file, or the same data under another name) is refused in one
line by identify, its cross-validation, predict and calibrate: counted twice it narrows the
intervals and weighs one run double; as a held-out copy of a tuning test a fit is judged as
a prediction."""

import shutil

import numpy as np
import pytest

from vehval.cli import main


def _csv_test(tmp_path, name="run1_dyno.csv", fuel_sign=1.0):
    """One conventional test file (speed, force, engine speed, fuel) and its template."""
    t = np.arange(0.0, 120.0, 0.1)
    v = np.clip(10 * np.sin(np.pi * t / 60.0), 0, None)
    path = tmp_path / name
    path.write_text("Time,Speed,Force,Engine,Fuel\n" + "".join(
        f"{a:.1f},{b:.3f},{200 + 1500 * c:.1f},{900 + 100 * b:.0f},"
        f"{fuel_sign * (0.2 + 0.1 * b):.3f}\n"
        for a, b, c in zip(t, v, np.gradient(v, t))))
    tpl = tmp_path / "t.yaml"
    tpl.write_text(
        "template_version: 1\nfiles:\n"
        "  - {match: '*_dyno.csv', source: dyno, format: csv, time: {column: Time, unit: s},\n"
        "     channels: {Speed: {name: veh_spd_test, unit: m/s},\n"
        "                Force: {name: veh_frc_in_test, unit: N},\n"
        "                Engine: {name: eng_spd_out_test, unit: rpm},\n"
        "                Fuel: {name: fuel_rate_test, unit: g/s}}}\n")
    return path, tpl


@pytest.fixture
def twin(tmp_path):
    """A test file and a byte-identical copy under another name."""
    f, tpl = _csv_test(tmp_path)
    copy = tmp_path / "copy_dyno.csv"
    shutil.copyfile(f, copy)
    return f, copy, tpl


def _one_error_line(capsys, rc):
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    return err[0]


@pytest.mark.parametrize("same_file", [True, False])
def test_identify_refuses_a_test_given_twice(twin, tmp_path, capsys, same_file):
    f, copy, tpl = twin
    out = tmp_path / "v.yaml"
    rc = main(["identify", str(f), str(f if same_file else copy), "-t", str(tpl),
               "-o", str(out)])
    line = _one_error_line(capsys, rc)
    assert ("it is the same test" if same_file else
            "copy_dyno: it is the same data as run1_dyno") in line
    assert "give each test run once" in line and not out.exists()


def test_cross_validation_refuses_a_copy(twin, tmp_path, capsys):
    """Leave-one-out would predict a test from its own copy and call it held out."""
    f, copy, tpl = twin
    rc = main(["identify", str(f), str(copy), "-t", str(tpl), "--cross-validate"])
    assert "the same data as run1_dyno" in _one_error_line(capsys, rc)


def test_predict_refuses_a_test_given_twice(twin, capsys):
    f, copy, tpl = twin
    rc = main(["predict", "cruze_diesel_2014", str(f), str(copy), "-t", str(tpl)])
    assert "the same data as run1_dyno" in _one_error_line(capsys, rc)


@pytest.mark.parametrize("same_file", [True, False])
def test_calibrate_refuses_a_holdout_that_is_a_tuning_test(twin, tmp_path, capsys, same_file):
    """Before, the tuning test given again as --holdout was counted as a held-out test
    (its fitted error reported as a prediction)."""
    f, copy, tpl = twin
    out = tmp_path / "cal"
    rc = main(["calibrate", str(f), "-t", str(tpl), "--vehicle", "cruze_diesel_2014",
               "--holdout", str(f if same_file else copy), "-o", str(out)])
    line = _one_error_line(capsys, rc)
    assert line.startswith(f"vehval: error: --holdout {'run1' if same_file else 'copy'}_dyno: it")
    assert "a held-out test must be another test run" in line and not out.exists()


def test_calibrate_refuses_a_tuning_test_given_twice(twin, tmp_path, capsys):
    f, copy, tpl = twin
    out = tmp_path / "cal"
    rc = main(["calibrate", str(f), str(copy), "-t", str(tpl), "--vehicle",
               "cruze_diesel_2014", "-o", str(out)])
    assert "given twice as a tuning test" in _one_error_line(capsys, rc)
    assert not out.exists()
