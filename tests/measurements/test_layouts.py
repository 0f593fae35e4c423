"""The layouts people have (issue 9, part 2): one-column and headerless files, units in the header,
tables of drop and rebound heights, runs side by side, spreadsheets (phyphox's .xlsx and .xls),
several files at once -- and no reader crashes on arbitrary text (hypothesis)."""

import builtins

import numpy as np
import pytest
from helpers import shared_file
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vrcal.errors import DataError, UsageError, VrcalError
from vrcal.measurements import (
    FORMATS,
    ApexHeights,
    ImpactTimes,
    Runs,
    Trajectory,
    detect_format,
    read_measurement,
    read_measurements,
)
from vrcal.model.restitution import STANDARD_GRAVITY_M_PER_S2 as G


def impact_times(H=1.0, eps=0.85, n=10):
    v0 = np.sqrt(2 * G * H)
    return np.sqrt(2 * H / G) + np.concatenate([[0.0], np.cumsum(2.0 * eps ** np.arange(1, n) * v0 / G)])


def fall(n=60, fs=100.0, H=1.2):
    t = np.arange(n) / fs
    return t, np.maximum(H - 0.5 * G * t * t, 0.0) + 0.2 * (t > 0.5)


def write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


# --------------------------------------------------------------------------- one column, no header


@pytest.mark.parametrize("header", ["t_impact", "time", "t", "Impacts", "t (s)", "T_IMPACT [s]", None])
def test_one_numeric_column_is_impact_times_whatever_its_name(tmp_path, header):
    t = impact_times()
    lines = ([header] if header else []) + [repr(float(v)) for v in t]
    p = write(tmp_path, "one.csv", "\n".join(lines) + "\n")
    assert detect_format(p) == "impacts"
    data = read_measurement(p)
    assert isinstance(data, ImpactTimes)
    np.testing.assert_allclose(data.t_s, t)


def test_one_column_in_ms_and_one_with_a_decimal_comma_without_header(tmp_path):
    t = impact_times()
    ms = write(tmp_path, "ms.csv", "t_impact (ms)\n" + "\n".join(f"{v * 1e3:.4f}" for v in t) + "\n")
    np.testing.assert_allclose(read_measurement(ms).t_s, t, atol=1e-7)
    comma = write(tmp_path, "comma.csv", "\n".join(f"{v:.6f}".replace(".", ",") for v in t) + "\n")
    np.testing.assert_allclose(read_measurement(comma).t_s, t, atol=1e-6)


@pytest.mark.parametrize("sep", [",", ";", "\t", "   "])
def test_headerless_two_columns_are_t_and_y(tmp_path, sep):
    t, y = fall()
    p = write(tmp_path, "ty.txt", "\n".join(f"{float(a)!r}{sep}{float(b)!r}" for a, b in zip(t, y)) + "\n")
    assert detect_format(p) == "trajectory"
    data = read_measurement(p)
    assert isinstance(data, Trajectory)
    np.testing.assert_allclose(data.y_m, y)
    assert any("no header" in n for n in data.notes)
    assert list(data.lines[:3]) == [1, 2, 3]


def test_headerless_three_columns_ask_for_a_header(tmp_path):
    t, y = fall()
    p = write(tmp_path, "three.txt", "\n".join(f"{a},{b},7" for a, b in zip(t, y)) + "\n")
    with pytest.raises(DataError, match=r"three\.txt:1: no header row"):
        read_measurement(p)


@pytest.mark.parametrize("unit,factor", [("m", 1.0), ("cm", 1e-2), ("mm", 1e-3)])
def test_units_in_the_header_are_converted(tmp_path, unit, factor):
    t, y = fall()
    body = "\n".join(f"{float(a) * 1e3!r},{float(b) / factor!r}" for a, b in zip(t, y))
    p = write(tmp_path, "u.csv", f"t (ms),y ({unit})\n" + body)
    data = read_measurement(p)
    np.testing.assert_allclose(data.t_s, t, atol=1e-12)
    np.testing.assert_allclose(data.y_m, y, atol=1e-12)


# --------------------------------------------------------------------------- drop tables


@pytest.mark.parametrize("header,scale", [("H,h", 1.0), ("drop (cm),rebound (cm)", 100.0),
                                          ("trial;H [mm];h1 [mm]", 1000.0), ("Drop height,Rebound height", 1.0)])
def test_a_drop_table_is_read_as_one_run_per_trial(tmp_path, header, scale):
    rows = [(0.5, 0.41), (1.0, 0.80), (1.5, 1.17), (2.0, 1.52)]
    sep = ";" if ";" in header else ","
    trial = header.startswith("trial")
    lines = [header] + [sep.join(([str(i)] if trial else []) + [f"{H * scale:g}", f"{h * scale:g}"])
                        for i, (H, h) in enumerate(rows)]
    p = write(tmp_path, "table.csv", "\n".join(lines) + "\n")
    assert detect_format(p) == "drops"
    data = read_measurement(p)
    assert isinstance(data, Runs) and data.kind == "apexes" and len(data.runs) == 4
    for run, (H, h) in zip(data.runs, rows):
        assert isinstance(run, ApexHeights) and list(run.bounce) == [0, 1]
        np.testing.assert_allclose(run.h_m, [H, h])
    assert data.labels[0] == "row 1 (line 2)"


def test_a_drop_table_with_further_rebounds_and_a_unit_given_once(tmp_path):
    p = write(tmp_path, "t.csv", "H (cm),h1,h2\n100,80,64\n150,120,\n")
    data = read_measurement(p)
    np.testing.assert_allclose(data.runs[0].h_m, [1.0, 0.8, 0.64])
    assert list(data.runs[1].bounce) == [0, 1]
    assert any("has no unit: taken as cm" in n for n in data.notes)


def test_two_apex_rows_give_one_drop(tmp_path):
    p = write(tmp_path, "two.csv", "bounce,h (cm)\n0,110\n1,86.77\n")
    data = read_measurement(p)
    assert isinstance(data, ApexHeights)
    np.testing.assert_allclose(data.h_m, [1.10, 0.8677])


def test_the_real_first_rebound_table_is_read():
    data = read_measurement(shared_file("realval/giiulia_method1/golf_110cm_first_rebound.csv"))
    assert isinstance(data, ApexHeights) and data.h_m.size == 2


# --------------------------------------------------------------------------- several files, runs side by side


def test_several_files_of_one_kind_are_runs(tmp_path):
    a = write(tmp_path, "a.csv", "t\n" + "\n".join(repr(float(v)) for v in impact_times(0.8)) + "\n")
    b = write(tmp_path, "b.csv", "t\n" + "\n".join(repr(float(v)) for v in impact_times(1.2)) + "\n")
    data = read_measurements([a, b])
    assert isinstance(data, Runs) and data.labels == (str(a), str(b))
    t, y = fall()
    c = write(tmp_path, "c.csv", "t,y\n" + "\n".join(f"{float(u)!r},{float(v)!r}" for u, v in zip(t, y)) + "\n")
    with pytest.raises(UsageError, match="one kind"):
        read_measurements([a, c])


def test_columns_of_the_same_name_are_runs_side_by_side(tmp_path):
    t1, t2 = impact_times(0.8, n=8), impact_times(0.8, n=6)
    lines = ['"Event time (s)","Interval (s)",,"Event time (s)","Interval (s)"']
    for i in range(8):
        second = f"{float(t2[i])!r},0" if i < 6 else ","
        lines.append(f"{float(t1[i])!r},0,,{second}")
    data = read_measurement(write(tmp_path, "side.csv", "\n".join(lines) + "\n"))
    assert isinstance(data, Runs) and [r.t_s.size for r in data.runs] == [8, 6]


# --------------------------------------------------------------------------- spreadsheets


def test_phyphox_xls_export_reads_its_all_sheet():
    pytest.importorskip("xlrd")
    data = read_measurement(shared_file("realval/giiulia_phyphox_excel/tennis_ball/Lancio 1, tennis, 65.xls"))
    csv = read_measurement(shared_file("realval/giiulia/tennis_65cm_L1.csv"))
    np.testing.assert_allclose(data.t_s, csv.t_s, atol=1e-6)
    assert data.source.endswith("[All]")


def test_phyphox_xlsx_export_and_a_named_sheet():
    pytest.importorskip("openpyxl")
    data = read_measurement(shared_file("realval/giiulia_phyphox_excel/pingpong_ball/Lancio1,30cm.xlsx"))
    csv = read_measurement(shared_file("realval/giiulia/pingpong_30cm_L1.csv"))
    np.testing.assert_allclose(data.t_s, csv.t_s, atol=1e-6)
    golf = read_measurement(shared_file("realval/giiulia_phyphox_excel/golf_ball/data_golfball.xlsx"), sheet="100 cm")
    assert isinstance(golf, Runs) and len(golf.runs) == 4
    with pytest.raises(UsageError, match="no sheet 'nope'.*'80 cm'"):
        read_measurement(shared_file("realval/giiulia_phyphox_excel/golf_ball/data_golfball.xlsx"), sheet="nope")


def test_a_written_workbook_is_a_table_like_any_other(tmp_path):
    openpyxl = pytest.importorskip("openpyxl")
    wb = openpyxl.Workbook()
    ws = wb.active
    ws.title = "drops"
    ws.append(["H (cm)", "h (cm)"])
    for H, h in [(50, 41), (100, 80), (150, 117)]:
        ws.append([H, h])
    path = tmp_path / "table.xlsx"
    wb.save(path)
    data = read_measurement(path)
    assert isinstance(data, Runs) and len(data.runs) == 3
    np.testing.assert_allclose(data.runs[1].h_m, [1.0, 0.8])


def test_a_missing_spreadsheet_library_is_a_one_line_hint(monkeypatch):
    path = shared_file("realval/giiulia_phyphox_excel/tennis_ball/Lancio 1, tennis, 65.xls")
    real_import = builtins.__import__

    def no_xlrd(name, *args, **kwargs):
        if name == "xlrd":
            raise ImportError("no xlrd")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_xlrd)
    with pytest.raises(UsageError, match=r"needs xlrd: install the optional extra: pip install 'vrcal\[excel\]'"):
        read_measurement(path)


# --------------------------------------------------------------------------- no crash on arbitrary input


CELLS = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr), st.integers(-10**6, 10**6).map(str),
                  st.sampled_from(["t", "y", "h", "H", "bounce", "time (ms)", "y (px)", "drop", "rebound", "",
                                   "nan", "1,5", "-", "x", "#", '"', "mass_A", "0.0687", "84.1"]))
LINES = st.lists(st.lists(CELLS, min_size=1, max_size=4).map(lambda cs: st.sampled_from([",", ";", "\t", " "]).map(
    lambda sep: sep.join(cs))), min_size=0, max_size=30)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data(), fmt=st.sampled_from([None, *FORMATS]))
def test_no_reader_crashes_on_arbitrary_tables(tmp_path_factory, data, fmt):
    lines = [data.draw(line) for line in data.draw(LINES)]
    path = tmp_path_factory.mktemp("fuzz") / "f.csv"
    path.write_text("\n".join(lines) + "\n")
    try:
        read_measurement(path, fmt, fs_hz=data.draw(st.sampled_from([None, 30.0])),
                         scale_m_per_px=data.draw(st.sampled_from([None, 0.001])))
    except VrcalError:
        pass


@settings(max_examples=200, deadline=None)
@given(text=st.text(max_size=400))
def test_no_reader_crashes_on_arbitrary_text(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("text") / "f.txt"
    path.write_text(text, encoding="utf-8", errors="surrogatepass") if "\ud800" not in text else path.write_bytes(b"x")
    try:
        read_measurement(path)
    except VrcalError:
        pass
