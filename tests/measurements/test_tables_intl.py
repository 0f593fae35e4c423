"""Tables as classes write them in their own languages and programs (a probe's findings): numbered trial
columns whatever the word, height columns named in German, French, Spanish and Italian, Google Sheets' quoted
decimal commas, grouped thousands, units in the cells, two-row headers, title lines with --format, and the
advice of the messages. Every table is planted with a known epsilon."""

import numpy as np
import pytest

from vrcal.errors import DataError
from vrcal.measurements import Runs, Trajectory, read_measurement
from vrcal.model.restitution import STANDARD_GRAVITY_M_PER_S2 as G

EPS = 0.77
DROPS_CM = (40.0, 60.0, 80.0, 100.0, 120.0)


def write(tmp_path, name, text, encoding="utf-8"):
    path = tmp_path / name
    path.write_bytes(text.encode(encoding))
    return str(path)


def rebounds_cm(n_trials=3, eps=EPS, seed=1):
    """{drop height [cm]: [rebound heights, cm, to 0.1 cm]} of ``n_trials`` trials, h = eps^2 H (+- 0.3 %)."""
    rng = np.random.default_rng(seed)
    return {H: [round(eps ** 2 * H * (1 + 0.003 * rng.standard_normal()), 1) for _ in range(n_trials)]
            for H in DROPS_CM}


def eps_of(runs):
    """Least-squares epsilon of a drop table's first rebounds: h = eps^2 H."""
    H = np.array([r.h_m[0] for r in runs.runs])
    h = np.array([r.h_m[1] for r in runs.runs])
    return float(np.sqrt(np.sum(h * H) / np.sum(H * H)))


def de(x):
    return f"{x:.1f}".replace(".", ",")


def trials_table(header, sep=";", comma=True, average=False):
    """A drop table with three trials per drop height side by side under ``header``."""
    lines = [header]
    for H, hs in rebounds_cm().items():
        cells = [H, *hs] + ([sum(hs) / 3] if average else [])
        lines.append(sep.join(de(v) if comma else f"{v:.1f}" for v in cells))
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("header", [
    "Fallhöhe in cm;h1 in cm;h2 in cm;h3 in cm",                                  # probe: read as bounces, 0.827
    "Fallhöhe (cm);Rückprallhöhe 1 (cm);Rückprallhöhe 2 (cm);Rückprallhöhe 3 (cm)",  # probe: 5 trials of 15
    "hauteur de chute (cm);hauteur de rebond 1 (cm);hauteur de rebond 2 (cm);hauteur de rebond 3 (cm)",
    "Fallhöhe (cm);1. Versuch (cm);2. Versuch (cm);3. Versuch (cm)",                # probe: refused
    "Drop height (cm);Rebound height 1 (cm);Rebound height 2 (cm);Rebound height 3 (cm)",
    "altura de caída (cm);intento 1 (cm);intento 2 (cm);intento 3 (cm)",
])
def test_numbered_trial_columns_are_trials_whatever_the_word(tmp_path, header):
    got = read_measurement(write(tmp_path, "t.csv", trials_table(header)))
    assert isinstance(got, Runs) and len(got.runs) == 15
    assert all(r.bounce.tolist() == [0, 1] for r in got.runs)
    assert abs(eps_of(got) - EPS) < 0.003
    assert not any("not read" in n for n in got.notes)


def test_gcse_drop_n_columns_beside_height_dropped_from_are_trials(tmp_path):
    """p2/real/gcse_tabletennis_labelled.csv (refused: 'a drop table needs a drop-height column'); the
    published numbers, eps 0.8185 by least squares h = eps^2 H."""
    text = ("Height dropped from/cm,Drop 1/cm,Drop 2/cm,Drop 3/cm,Average/cm\n100,65,65,63,63.7\n80,51,51,51,51\n"
            "60,42,42,42,42\n40,34,35,36,22\n20,15,16,15,15.3\n")
    got = read_measurement(write(tmp_path, "gcse.csv", text))
    assert len(got.runs) == 15 and abs(eps_of(got) - 0.8185) < 0.001
    assert any("'Average' not read (derived from the trials)" in n for n in got.notes)


def test_successive_rebounds_numbered_h1_h2_stay_rebounds(tmp_path):
    rows = "".join(f"{H:.0f},{EPS**2 * H:.2f},{EPS**4 * H:.2f},{EPS**6 * H:.2f}\n" for H in DROPS_CM)
    got = read_measurement(write(tmp_path, "r.csv", "H (cm),h1 (cm),h2 (cm),h3 (cm)\n" + rows))
    assert len(got.runs) == 5 and all(r.bounce.tolist() == [0, 1, 2, 3] for r in got.runs)
    assert any("successive rebounds" in n for n in got.notes)


@pytest.mark.parametrize("word", ["Mittelwert", "moyenne", "promedio", "Average"])
def test_an_average_column_is_named_derived_not_advised_as_a_rebound(tmp_path, word):
    header = f"Fallhöhe (cm);Versuch 1 (cm);Versuch 2 (cm);Versuch 3 (cm);{word} (cm)"
    got = read_measurement(write(tmp_path, "m.csv", trials_table(header, average=True)))
    assert len(got.runs) == 15 and abs(eps_of(got) - EPS) < 0.003
    assert any(f"'{word}' not read (derived from the trials)" in n for n in got.notes)
    assert not any("h2" in n for n in got.notes)


def flight(eps=0.74, H=1.2, fs=60.0, n_bounces=3):
    """(t [s], y [m]) of a ball dropped from H [m] bouncing with eps, sampled at fs [Hz]."""
    v0 = np.sqrt(2 * G * H)
    flights = 2 * eps ** np.arange(1, n_bounces + 1) * v0 / G
    impacts = np.sqrt(2 * H / G) + np.concatenate([[0.0], np.cumsum(flights)])
    t = np.arange(0.0, impacts[-1], 1 / fs)
    k = np.searchsorted(impacts, t)
    d = t - np.where(k > 0, impacts[np.maximum(k - 1, 0)], 0.0)
    y = np.where(k == 0, H - 0.5 * G * t * t, eps ** k * v0 * d - 0.5 * G * d * d)
    return t, np.maximum(y, 0.0)


@pytest.mark.parametrize("header, unit, encoding", [
    ("Zeit [s];Höhe [m]", 1.0, "utf-8"),
    ("Zeit t in s;Höhe h in m", 1.0, "utf-8"),            # the German school header
    ("Zeit t / s;Höhe h / m", 1.0, "utf-8"),
    ("temps t (s);hauteur h (m)", 1.0, "utf-8-sig"),
    ("tiempo (s);altura (cm)", 100.0, "utf-8"),
    ("tempo (s);altezza (m)", 1.0, "utf-16"),
    ("t (s);z (m)", 1.0, "utf-8"),
    ("Zeit (s);Hoehe (mm)", 1000.0, "utf-8"),
])
def test_height_columns_in_a_class_language_are_trajectories(tmp_path, header, unit, encoding):
    t, y = flight()
    body = "".join(f"{a:.4f};{b * unit:.4f}\n".replace(".", ",") for a, b in zip(t, y))
    got = read_measurement(write(tmp_path, "traj.csv", header + "\n" + body, encoding))
    assert isinstance(got, Trajectory) and got.t_s.size == t.size
    assert np.allclose(got.y_m, y, atol=1e-4)


def test_a_failing_column_look_up_names_what_the_column_may_be_called(tmp_path):
    path = write(tmp_path, "w.csv", "Zeit (s);Wert (m)\n0;1\n0,1;0,9\n")
    with pytest.raises(DataError) as err:
        read_measurement(path, "trajectory")
    assert "columns: Zeit, Wert" in str(err.value) and "'Höhe'" in str(err.value) and "'y (m)'" in str(err.value)
    with pytest.raises(DataError) as err:
        read_measurement(write(tmp_path, "i.csv", "Nr;Dauer\n1;0,5\n2;0,9\n"), "impacts")
    assert "columns: Nr, Dauer" in str(err.value) and "'Zeit'" in str(err.value)


def test_google_sheets_csv_quoted_decimal_commas_are_read(tmp_path):
    """Google Sheets in a decimal-comma locale saves '1,"0,9517"' (refused: '3 cells but the header names 2
    columns (a decimal comma with comma separators?)')."""
    rows = rebounds_cm(1)
    drops = "Versuch,Fallhöhe (cm),Rückprallhöhe (cm)\n" + "".join(
        f'{k},"{de(H)}","{de(hs[0])}"\n' for k, (H, hs) in enumerate(rows.items(), start=1))
    got = read_measurement(write(tmp_path, "d.csv", drops))
    assert len(got.runs) == 5 and abs(eps_of(got) - EPS) < 0.003
    t, y = flight()
    traj = "t (s),y (m)\n" + "".join(f'"{de4(a)}","{de4(b)}"\n' for a, b in zip(t, y))
    got = read_measurement(write(tmp_path, "t.csv", traj))
    assert isinstance(got, Trajectory) and np.allclose(got.y_m, y, atol=1e-4)
    impacts = np.sqrt(2 / G) + np.concatenate([[0.0], np.cumsum(2 * 0.8 ** np.arange(1, 8) * np.sqrt(2 * G) / G)])
    got = read_measurement(write(tmp_path, "i.csv", "Nr,Zeit (s)\n" + "".join(
        f'{k},"{de4(v)}"\n' for k, v in enumerate(impacts, start=1))))
    assert got.kind == "impacts" and np.allclose(got.t_s, impacts, atol=1e-4)


def de4(x):
    return f"{x:.4f}".replace(".", ",")


def grouped(x_mm, decimals):
    """``x_mm`` written as a German spreadsheet does: thousands grouped by '.', a decimal comma."""
    text = f"{x_mm:,.{decimals}f}"
    return text.replace(",", "_").replace(".", ",").replace("_", ".")


@pytest.mark.parametrize("decimals", [0, 1])
def test_thousands_grouped_by_a_dot_are_read(tmp_path, decimals):
    """'1.200,0' was refused without a hint; '1.200' beside '800' read as 1.2 mm ('columns swapped?')."""
    rows = "".join(f"{k};{grouped(10 * H, decimals)};{grouped(10 * hs[k - 1], 1 if decimals else 0)}\n"
                   for H, hs in rebounds_cm().items() for k in (1, 2, 3))
    got = read_measurement(write(tmp_path, "g.csv", "Versuch;Fallhöhe (mm);Rückprallhöhe (mm)\n" + rows))
    assert len(got.runs) == 15 and abs(eps_of(got) - EPS) < 0.003
    assert sorted({r.h_m[0] for r in got.runs}) == pytest.approx([H / 100 for H in DROPS_CM])
    assert any("thousands separator" in n for n in got.notes)
    t, y = flight(H=1.5)
    traj = "Zeit (s);Höhe (mm)\n" + "".join(f"{de4(a)};{grouped(1000 * b, 1)}\n" for a, b in zip(t, y))
    got = read_measurement(write(tmp_path, "t.csv", traj))
    assert np.allclose(got.y_m, y, atol=1e-4)


def test_thousands_or_decimals_that_cannot_be_told_apart_are_refused_saying_so(tmp_path):
    rows = "".join(f"{k};{grouped(H * 10 + 1000, 0)};{grouped(hs[0] * 10 + 1000, 0)}\n"
                   for k, (H, hs) in enumerate(rebounds_cm().items(), start=1))
    with pytest.raises(DataError) as err:
        read_measurement(write(tmp_path, "b.csv", "Versuch;Fallhöhe (mm);Rückprallhöhe (mm)\n" + rows))
    msg = str(err.value)
    assert "b.csv:2: '1.400' in column 'Fallhöhe (mm)'" in msg and "groups thousands (1400)" in msg
    assert "without thousands separators" in msg
    # decimals written to three places with a decimal point are decimals: '1.000;0.593'
    got = read_measurement(write(tmp_path, "m.csv", "H (m);h (m)\n1.000;0.593\n1.000;0.595\n"))
    assert got.runs[0].h_m.tolist() == [1.0, 0.593]
    # ... and so is '1.500' beside drops of '1' and '2' m, in a file whose rebounds use the same point (the
    # re-check found '1.500' read as 1500 and the table refused: 'heights look like mm')
    got = read_measurement(write(tmp_path, "w.csv", "H (m);h (m)\n1;0.562\n1.500;0.844\n2;1.125\n"))
    assert [r.h_m[0] for r in got.runs] == [1.0, 1.5, 2.0] and not any("thousands" in n for n in got.notes)


def test_a_drop_height_merged_over_its_trials_in_xlsx_applies_to_each_row(tmp_path):
    """xlsx_merged_H.xlsx: 'empty cell in column 'Fallhöhe'' before (a read-only workbook has no merges)."""
    openpyxl = pytest.importorskip("openpyxl")
    wb = openpyxl.Workbook()
    ws = wb.active
    ws.append(["Rückprall eines Tennisballs"])
    ws.merge_cells("A1:C1")
    ws.append(["Fallhöhe (cm)", "Versuch", "Rückprallhöhe (cm)"])
    for H, hs in rebounds_cm().items():
        first = ws.max_row + 1
        for k, h in enumerate(hs, start=1):
            ws.append([H if k == 1 else None, k, h])
        ws.merge_cells(f"A{first}:A{first + 2}")
    path = tmp_path / "merged.xlsx"
    wb.save(path)
    got = read_measurement(str(path))
    assert len(got.runs) == 15 and abs(eps_of(got) - EPS) < 0.003
    assert sorted({round(r.h_m[0], 6) for r in got.runs}) == [H / 100 for H in DROPS_CM]
    assert any("'Rückprall eines Tennisballs' is a title" in n for n in got.notes)


def test_an_ods_spreadsheet_is_named_and_told_to_save_as_xlsx_or_csv(tmp_path):
    import zipfile
    path = tmp_path / "lo.ods"
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("mimetype", "application/vnd.oasis.opendocument.spreadsheet")
        zf.writestr("META-INF/manifest.xml", "<manifest/>")
        zf.writestr("content.xml", "<office:document-content/>")
    with pytest.raises(DataError) as err:
        read_measurement(str(path))
    assert "OpenDocument spreadsheet (LibreOffice" in str(err.value) and "save it as .xlsx or .csv" in str(err.value)


@pytest.mark.parametrize("text, said", [
    ("H,h\n0.50 m,0.303 m\n", "(column 'H'): remove the unit from the cells; put it in the header: 'H (m)'"),
    ("H,h\n0.50,0.30 m\n", "(column 'h'): remove the unit from the cells; put it in the header: 'h (m)'"),
    ("Drop (cm),Rebound (cm)\n50 cm,30\n", "(column 'Drop'): remove the unit from the cells (the header gives it: "
                                           "'Drop (cm)')"),
    ("t,y\n" + "".join(f"{k / 60:.4f} s,1.0\n" for k in range(30)), "(column 't'): remove the unit from the cells; "
                                                                     "put it in the header: 't (s)'"),
])
def test_a_unit_in_the_cells_is_told_to_go_into_the_header_naming_the_column_as_written(tmp_path, text, said):
    with pytest.raises(DataError) as err:
        read_measurement(write(tmp_path, "u.csv", text))
    assert said in str(err.value) and "u.csv:2:" in str(err.value)


@pytest.mark.parametrize("fmt", [None, "drops"])
def test_a_title_line_is_skipped_with_or_without_format(tmp_path, fmt):
    """--format drops turned title skipping off ('3 cells but the header names 1 columns')."""
    rows = "".join(f"{k};{de(H)};{de(hs[k - 1])}\n" for H, hs in rebounds_cm().items() for k in (1, 2, 3))
    path = write(tmp_path, "t.csv", "Ballsprung Gruppe 3\nVersuch;Fallhöhe (cm);Rückprallhöhe (cm)\n" + rows)
    got = read_measurement(path, fmt)
    assert len(got.runs) == 15 and abs(eps_of(got) - EPS) < 0.003
    assert got.notes[0] == "line 1 'Ballsprung Gruppe 3' is a title: skipped"


@pytest.mark.parametrize("fmt", [None, "trajectory"])
def test_a_title_above_t_y_with_units_is_no_tracker_track_name(tmp_path, fmt):
    """'Videoanalyse Tennisball' above 't (s);y (cm)' was a 'Tracker data export' whose positions were 'taken
    as metres' before they were converted from cm."""
    t, y = flight()
    body = "".join(f"{de4(a)};{de(100 * b)}\n" for a, b in zip(t, y))
    got = read_measurement(write(tmp_path, "v.csv", "Videoanalyse Tennisball\nt (s);y (cm)\n" + body), fmt)
    assert np.allclose(got.y_m, y, atol=1e-3)
    assert "line 1 'Videoanalyse Tennisball' is a title: skipped" in got.notes
    assert not any("Tracker" in n or "taken as metres" in n for n in got.notes)


def test_a_tracker_multi_track_export_names_its_track_over_its_time_column(tmp_path):
    t, y = flight()
    body = "".join(f"{a:.6E}\t0.1\t{b:.6E}\t{a:.6E}\t0.5\t0.0\n" for a, b in zip(t, y))
    got = read_measurement(write(tmp_path, "m.txt", "#multi:\nmass A\t\t\tmass B\t\t\nt\tx\ty\tt\tx\ty\n" + body))
    assert np.allclose(got.y_m, y, atol=1e-5)
    assert got.notes[0].startswith("format: Tracker multi-track export; track 'mass A', whose y spans the most")


BOUNCY = "10 5 6 5 5.33\n20 11 11 11 11\n30 16 17 16 16.33\n40 22 22 22 22\n50 28 28 27 27.67\n"


@pytest.mark.parametrize("sep, header", [
    (" ", "Drop_height_cm Trial_1_cm Trial_2_cm Trial_3_cm Average_cm"),
    (",", "Drop height (cm),Trial 1 (cm),Trial 2 (cm),Trial 3 (cm),Average (cm)"),
])
@pytest.mark.parametrize("fmt", [None, "drops"])
def test_a_headerless_drop_table_is_told_the_header_that_reads_it(tmp_path, sep, header, fmt):
    """p2/real/bouncyball_scribd_as_published.csv: blank-separated, 'cannot tell the layout from the header
    '10 5 6 5 5.33'' where its comma twin said 'no header row'."""
    body = BOUNCY.replace(" ", sep)
    with pytest.raises(DataError) as err:
        read_measurement(write(tmp_path, "b.csv", body), fmt)
    assert f"b.csv:1: no header row: the first line holds numbers; for a drop height and its trials, give the " \
           f"file the header '{header}'" in str(err.value)
    got = read_measurement(write(tmp_path, "fixed.csv", header + "\n" + body))
    assert len(got.runs) == 15 and any("'Average' not read" in n for n in got.notes)
    assert abs(eps_of(got) - 0.738) < 0.01


@pytest.mark.parametrize("factor, unit", [(100, "cm"), (1000, "mm")])
def test_a_rebound_many_times_its_drop_is_a_unit_not_a_swap(tmp_path, factor, unit):
    """p4: 'H (m),h' over '1.00,55' was asked 'are the drop and rebound columns swapped?'."""
    from vrcal.measurements.plausibility import check
    rows = "".join(f"{H / 100:.2f},{hs[0] / 100 * factor:.1f}\n" for H, hs in rebounds_cm().items())
    data = read_measurement(write(tmp_path, "h.csv", "H (m),h\n" + rows))
    with pytest.raises(DataError) as err:
        check(data)
    assert f"is the rebound in {unit} and the drop in m? write each height column's unit in its header " \
           f"('h ({unit})', 'H (m)')" in str(err.value) and "swapped" not in str(err.value)
    swapped = "".join(f"{hs[0] / 100:.3f},{H / 100:.2f}\n" for H, hs in rebounds_cm().items())
    with pytest.raises(DataError, match="are the drop and rebound columns swapped"):
        check(read_measurement(write(tmp_path, "s.csv", "H (m),h (m)\n" + swapped)))


def test_a_text_drop_table_named_xlsx_is_told_its_own_format(tmp_path):
    path = write(tmp_path, "d.xlsx", "H (cm),h (cm)\n100,59\n80,47\n")
    with pytest.raises(DataError) as err:
        read_measurement(path)
    assert str(err.value).endswith("rename it to .csv, or give --format drops")
    assert len(read_measurement(path, "drops").runs) == 2


def test_repeated_time_columns_without_numbers_are_an_error_not_a_crash(tmp_path):
    """Found by the fuzz test: '0.0,t,t' over '0.0' ended in numpy's 'zero-size array' (printed_resolution of no
    number)."""
    with pytest.raises(DataError, match="only 0 impact"):
        read_measurement(write(tmp_path, "h.csv", "0.0,t,t\n0.0\n"))


@pytest.mark.parametrize("sep", [";", "\t"])
def test_a_header_of_two_rows_is_read_as_one(tmp_path, sep):
    """intl/de_two_row_header.csv ('4 cells but the header names 2 columns'): a name spanning the trials over
    their own names, as a spreadsheet's merged cell saves it."""
    body = trials_table("x", sep=sep).split("\n", 1)[1]
    head = sep.join(["Fallhöhe (cm)", "Rückprallhöhe (cm)", "", ""]) + "\n" + \
        sep.join(["", "1. Versuch", "2. Versuch", "3. Versuch"]) + "\n"
    got = read_measurement(write(tmp_path, "two.csv", "Ballsprung Klasse 10b\n" + head + body))
    assert len(got.runs) == 15 and abs(eps_of(got) - EPS) < 0.003
    assert "lines 2-3 are a header of two rows: read as one ('Fallhöhe (cm)', '1. Versuch (cm)', '2. Versuch (cm)', " \
           "'3. Versuch (cm)')" in got.notes


def test_a_headerless_pixel_track_is_not_told_it_is_a_drop_table(tmp_path):
    """The re-check: BenHagenau/ASEN2003's imp1 (x pixel, y pixel, time in s; 114 lines) was told the header
    'Drop height (cm),Trial 1 (cm),Trial 2 (cm)', which reads it as 114 trials."""
    t = np.arange(114) / 30.0
    y = 120.0 + 80.0 * np.abs(np.cos(2.0 * t))
    body = "".join(f"{310.0 + 0.1 * k:.1f},{b:.1f},{a:.4f}\n" for k, (a, b) in enumerate(zip(t, y)))
    with pytest.raises(DataError) as err:
        read_measurement(write(tmp_path, "imp1.csv", body))
    assert "no header row" in str(err.value) and "Trial 1" not in str(err.value)
    assert "name the columns (e.g. 't,y'" in str(err.value)
