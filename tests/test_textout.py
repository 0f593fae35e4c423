"""Human and machine output helpers (vrcal.textout)."""

import pytest

from vrcal.errors import UsageError
from vrcal.textout import MAX_COLUMNS, choose_format, epsilon, machine_document, ms, number, section, table


@pytest.mark.parametrize("value,digits,text", [
    (0.7661781385597868, 4, "0.7662"), (59.657, 4, "59.66"), (123456.0, 4, "123456"), (0.0, 4, "0"),
    (1.23456e-7, 3, "1.23e-07"), (None, 4, "-"), (float("nan"), 4, "nan"), (-0.00684, 2, "-0.0068"),
])
def test_number(value, digits, text):
    assert number(value, digits) == text


@pytest.mark.parametrize("value,text", [(0.7661781385597868, "0.766"), (0.9995, "0.9995"), (0.99999, "0.99999"),
                                        (1.0, "1.00"), (0.05, "0.0500"), (None, "-")])
def test_an_epsilon_below_one_never_prints_as_one(value, text):
    """A superball's 0.9995 was the headline 'ε = 1.000' (an edge-case probe)."""
    assert epsilon(value) == text


def test_ms():
    assert ms(0.06658514485303495) == "66.6 ms"


def test_choose_format_by_option_then_extension():
    assert choose_format(None, None) == "text"
    assert choose_format(None, "out.json") == "json"
    assert choose_format(None, "out.YML") == "yaml"
    assert choose_format("yaml", "out.yml") == "yaml" and choose_format("text", "out.txt") == "text"
    with pytest.raises(UsageError, match="--format yaml with -o 'out.json', a .json file"):
        choose_format("yaml", "out.json")
    with pytest.warns(UserWarning, match="names no format vrcal knows: wrote text"):
        assert choose_format(None, "out.dat") == "text"
    with pytest.raises(UsageError, match="known: text, json, yaml"):
        choose_format("xml", None)


def test_machine_document_leads_with_schema_version():
    doc = machine_document({"a": 1})
    assert list(doc) == ["schema_version", "a"]


def test_table_aligns_numbers_right_and_text_left():
    text = table([["basketball", "0.766"], ["tennis", "0.75"]], ["ball", "epsilon"])
    lines = text.splitlines()
    assert lines[0] == "ball        epsilon"
    assert lines[1] == "basketball    0.766"
    assert lines[2] == "tennis         0.75"
    assert all(len(line) <= MAX_COLUMNS for line in lines)


def test_section_aligns_keys():
    expected = "[ball]\n  epsilon  0.766\n  T        66.6 ms\n"
    assert section("[ball]", [("epsilon", "0.766"), ("T", "66.6 ms")]) == expected


def test_counted_says_one_bounce_and_three_bounces():
    """A refusal of one bounce said 'misses (16 phases x 1 bounces)'."""
    from vrcal.textout import counted

    assert [counted(n, "bounce") for n in (0, 1, 3)] == ["0 bounces", "1 bounce", "3 bounces"]
