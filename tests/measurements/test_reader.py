

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
