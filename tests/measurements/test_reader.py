

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
