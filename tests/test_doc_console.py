"""The matcher that compares the docs' console examples with real output (tests/doc_console.py)."""

import pytest
from doc_console import commands, compare, expected_status, number_matches


@pytest.mark.parametrize("shown,actual,ok", [
    ("0.7662", "0.7661781385597868", True),
    ("0.766", "0.7661781385597868", True),
    ("0.77", "0.7662", True),
    ("0.7662", "0.7663", False),
    ("0.77", "0.7649", False),
    ("571", "571", True),
    ("571", "572", False),
    ("1.2e-3", "0.00123", True),
    ("1.2e-3", "0.00126", False),
    ("-0.0068", "-0.00684", True),
])
def test_numbers_match_to_the_digits_shown(shown, actual, ok):
    assert number_matches(shown, actual) is ok


def test_text_must_match_and_blanks_collapse():
    assert compare("epsilon   0.766", "epsilon 0.76617") is None
    assert compare("epsilon 0.766", "epsilon: 0.766") is not None


def test_ellipsis_lines_and_inline():
    actual = "a 1\nb 2\nc 3\nd 4\n"
    assert compare("a 1\n...\nd 4", actual) is None
    assert compare("a 1\n...", actual) is None
    assert compare("...\nc 3\nd 4", actual) is None
    assert compare("a 1\nd 4", actual) is not None
    assert compare("wrote .../x.csv", "wrote /tmp/abc/x.csv") is None


def test_missing_and_extra_lines_are_reported():
    assert "not found" in compare("a 1\nz 9", "a 1\nb 2\n")
    assert "does not show" in compare("a 1", "a 1\nb 2\n")


def test_commands_and_continuations():
    block = "$ vrcal fit \\\n  basketball\nline 1\nline 2\n$ echo hi\nhi\n"
    assert commands(block) == [("vrcal fit \n  basketball", "line 1\nline 2"), ("echo hi", "hi")]


def test_exit_status_line():
    assert expected_status("vrcal: error: x\n[exit 2]\n") == (2, "vrcal: error: x")
    assert expected_status("fine\n") == (0, "fine\n")
