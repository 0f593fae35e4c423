

def test_a_yaml_result_of_vrcal_is_named_not_read_as_a_table(tmp_path):
    """`vrcal discover basketball.yaml` (a fit result) said 'line 10: 2 cells but the header names 1
    columns'; it says what the file is."""
    from click.testing import CliRunner

    from vrcal.cli import main

    out = tmp_path / "bb.yaml"
    assert CliRunner().invoke(main, ["fit", "basketball", "-o", str(out)]).exit_code == 0
    result = CliRunner().invoke(main, ["discover", str(out), "--ball", "tennis"])
    assert result.exit_code == 1
    assert "a YAML document of vrcal" in result.output and len(result.output.strip().splitlines()) == 1


def test_another_format_is_offered_only_when_it_reads_the_file(tmp_path):
    """A DDE tracker's 'x: .. y: ..' file read with --format trajectory was told '(the file reads as impacts:
    --format impacts)', and --format impacts then said \"'balltype 2' is not a number\": the hint names a
    format only when that format's parser reads the file."""
    import pytest

    from vrcal.errors import DataError
    from vrcal.measurements import read_measurement

    lines = ["cropping True", "balltype 2", "videoname Videos/ball2_1.mp4", "fps 24"]
    lines += [f"x: {184 + 0.5 * i} y: {110 + (i - 10) ** 2 / 4}" for i in range(30)]
    path = tmp_path / "ball2_1_data"
    path.write_bytes(("\r\n".join(lines) + "\r\n").encode())
    with pytest.raises(DataError) as err:
        read_measurement(path, fmt="trajectory")
    assert "no height column" in str(err.value) and "--format" not in str(err.value)
    with pytest.raises(DataError):
        read_measurement(path, fmt="impacts")   # the hint's format did not read it either


def test_trials_as_columns_are_refused_with_the_layout_that_reads(tmp_path):
    """A class's sheet with the trials as columns and the bounces as rows, naming no quantity nor unit
    (mjoel00/ASEN-2003's Method1_Data.csv: 'Data,Trial 1..Trial 10' over 'Bounce_1..3', inches said nowhere)
    was told only 'cannot tell the layout from the header ... (known formats: ...)'. It is named in one line
    with the layout that reads, and that layout reads."""
    import pytest

    from vrcal.errors import DataError
    from vrcal.measurements import read_measurement

    rows = {"Bounce_1": [18.125, 17.875, 17.750], "Bounce_2": [14.875, 14.500, 14.375],
            "Bounce_3": [12.250, 12.000, 11.625]}
    path = tmp_path / "Method1_Data.csv"
    path.write_text("Data,Trial 1,Trial 2,Trial 3\n" + "".join(f"{k},{','.join(f'{v:.3f}' for v in vs)}\n"
                                                              for k, vs in rows.items()))
    with pytest.raises(DataError) as err:
        read_measurement(path)
    msg = str(err.value)
    assert "trials as columns" in msg and "Bounce_1" in msg and "'Drop height (in),h1 (in),h2 (in)'" in msg
    assert "\n" not in msg and len(msg) < 400
    fixed = tmp_path / "one_per_row.csv"
    fixed.write_text("Drop height (in),h1 (in),h2 (in),h3 (in)\n"
                     + "".join(f"36,{a},{b},{c}\n" for a, b, c in zip(*rows.values())))
    got = read_measurement(fixed)
    assert len(got.runs) == 3 and got.runs[0].h_m[0] == 36 * 0.0254
