"""Tests of vrcal.fileio: bounded reads, the YAML loader that cannot be bombed, and writes that are
all-or-nothing and never replace what is not a regular file (issue 10)."""

import os
import stat
import threading
import time

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from vrcal.errors import DataError, UsageError, VrcalError
from vrcal.fileio import (
    MAX_YAML_BYTES,
    MAX_YAML_DEPTH,
    atomic_write,
    parse_yaml,
    read_bytes_bounded,
    read_yaml,
    write_files,
)


def billion_laughs(levels=9, width=9):
    """A value that expands to width**levels strings: 387 million for the defaults."""
    parts = ['&a0 "lol"'] + [f"&a{i} [" + ", ".join([f"*a{i - 1}"] * width) + "]" for i in range(1, levels + 1)]
    return "[" + ", ".join(parts) + "]"


# --------------------------------------------------------------------------- bounded reads


def test_dev_zero_is_refused_at_the_limit_not_read_to_the_end():
    with pytest.raises(DataError, match=r"/dev/zero: larger than the limit of 1 KiB for a test file"):
        read_bytes_bounded("/dev/zero", 1024, "test")


def test_a_file_at_the_limit_is_read_whole(tmp_path):
    p = tmp_path / "f"
    p.write_bytes(b"x" * 1024)
    assert read_bytes_bounded(p, 1024) == b"x" * 1024
    p.write_bytes(b"x" * 1025)
    with pytest.raises(DataError, match="limit of 1 KiB"):
        read_bytes_bounded(p, 1024)


@pytest.mark.parametrize("path", ["/dev/zero", "/dev/urandom"])
def test_read_yaml_of_an_endless_device_names_the_limit(path):
    with pytest.raises(DataError, match=f"larger than the limit of {MAX_YAML_BYTES // 2**20} MiB for a scene file"):
        read_yaml(path, "scene")


def test_read_yaml_of_a_directory_or_a_missing_file(tmp_path):
    with pytest.raises(DataError, match="is a directory"):
        read_yaml(tmp_path, "scene")
    with pytest.raises(UsageError, match="no such scene file"):
        read_yaml(tmp_path / "nope.yaml", "scene")


# --------------------------------------------------------------------------- the YAML loader


@pytest.mark.parametrize("where", ["name: {b}", "K_per_s: {b}", "schema_version: {b}"])
def test_billion_laughs_is_refused_before_it_expands(where):
    t0 = time.perf_counter()
    with pytest.raises(DataError, match=r"x.yaml:1: alias \*a4: the aliases repeat more than 10000 values"):
        parse_yaml(where.format(b=billion_laughs()), "x.yaml")
    assert time.perf_counter() - t0 < 5  # expanded, it would take about a minute and gigabytes


def test_anchors_aliases_and_merge_keys_copy_a_balls_settings():
    """Aliases were all refused ('aliases are not allowed'); a bounded number of repeated values is read,
    merge keys included, and a merged key may be overridden (not a duplicate)."""
    assert parse_yaml("a: &a 1\nb: 2\nc: *a\n", "x.yaml") == {"a": 1, "b": 2, "c": 1}
    doc = parse_yaml("bodies:\n  - &b {name: s, mass_kg: 0.2, virtual_body: {x_m: 0.01, v_m_per_s: 0.1}}\n"
                     "  - {<<: *b, name: t}\n", "x.yaml")
    assert doc["bodies"][1] == {"name": "t", "mass_kg": 0.2, "virtual_body": {"x_m": 0.01, "v_m_per_s": 0.1}}
    with pytest.raises(DataError, match=r"x.yaml:2: duplicate key 'y'"):
        parse_yaml("a: &a {x: 1}\nb: {<<: *a, y: 1, y: 2}\n", "x.yaml")


def test_aliases_repeating_more_than_the_limit_are_refused_with_the_line():
    from vrcal.fileio import MAX_YAML_ALIAS_VALUES

    n = MAX_YAML_ALIAS_VALUES // 100           # aliases of a list of 99 numbers: 100 values each
    text = "a: &a [" + ", ".join(["1"] * 99) + "]\n" + "".join(f"k{i}: *a\n" for i in range(n))
    assert len(parse_yaml(text, "x.yaml")) == 1 + n
    with pytest.raises(DataError, match=rf"x.yaml:{2 + n}: alias \*a: the aliases repeat"):
        parse_yaml(text + "last: *a\n", "x.yaml")


@pytest.mark.parametrize("text", [
    "x: " + "[" * 100_000 + "]" * 100_000,
    "x: " + "{a: " * 1000 + "1" + "}" * 1000,
    "".join(" " * i + f"k{i}:\n" for i in range(200)) + " " * 200 + "v: 1\n",
])
def test_deep_nesting_is_refused_with_the_limit(text):
    with pytest.raises(DataError, match=f"nested deeper than the limit of {MAX_YAML_DEPTH} levels"):
        parse_yaml(text, "deep.yaml")


def test_nesting_up_to_the_limit_is_read():
    depth = MAX_YAML_DEPTH - 1  # the document's top mapping is one level
    doc = parse_yaml("x: " + "[" * depth + "1" + "]" * depth, "ok.yaml")
    doc = doc["x"]
    for _ in range(depth):
        doc = doc[0]
    assert doc == 1
    with pytest.raises(DataError, match="nested deeper"):
        parse_yaml("x: " + "[" * (depth + 1) + "1" + "]" * (depth + 1), "deep.yaml")


def test_a_duplicate_key_names_both_lines():
    with pytest.raises(DataError, match=r"s.yaml:4: duplicate key 'basketball' \(first on line 2\)"):
        parse_yaml("balls:\n  basketball: {name: a}\n  volleyball: {name: b}\n  basketball: {name: c}\n", "s.yaml")


def test_the_same_key_in_different_mappings_is_fine():
    assert parse_yaml("a: {x: 1}\nb: {x: 2}\n", "s.yaml") == {"a": {"x": 1}, "b": {"x": 2}}


@pytest.mark.parametrize("text, what", [
    ("schema_version: " + "9" * 100_000, "cannot read the value"),
    ("K_per_s: 1" + "0" * 400, "integer of 401 digits: larger than any number vrcal computes with"),
    ("when: 2001-13-45", "cannot read the value"),
    ("x: !!python/object/apply:os.system ['true']", "could not determine a constructor"),
    ("a: [1, 2", "malformed YAML"),
])
def test_values_python_cannot_build_are_yaml_errors(text, what):
    with pytest.raises(DataError, match=what):
        parse_yaml(text, "x.yaml")


def test_numbers_in_e_notation_are_numbers():
    assert parse_yaml("a: 1e-3\nb: -2E+5\nc: 1.5e3\nd: 1e\n", "x") == {"a": 0.001, "b": -2e5, "c": 1500.0, "d": "1e"}


@settings(max_examples=150, deadline=None)
@given(st.text(max_size=300))
def test_arbitrary_text_gives_a_document_or_a_data_error(text):
    try:
        parse_yaml(text, "fuzz.yaml")
    except DataError:
        pass


# --------------------------------------------------------------------------- writing


def _no_temporaries(d):
    return [n for n in os.listdir(d) if n.startswith(".") or n.endswith(".tmp")] == []


def test_write_files_writes_all_or_none(tmp_path):
    ok, bad = tmp_path / "a.txt", tmp_path / "missing" / "b.txt"
    with pytest.raises(UsageError, match="does not exist"):
        write_files({ok: "a", bad: "b"})
    assert not ok.exists() and _no_temporaries(tmp_path)
    write_files({ok: "a", tmp_path / "c.bin": b"\x00"})
    assert ok.read_text() == "a" and (tmp_path / "c.bin").read_bytes() == b"\x00"


def test_write_files_removes_the_directories_it_made_when_it_fails(tmp_path):
    report = tmp_path / "new" / "report"
    (tmp_path / "blocker").mkdir()  # a directory where the last file should go
    with pytest.raises(UsageError, match="is a directory"):
        write_files({report / "a.txt": "a", tmp_path / "blocker": "b"}, directories=[report])
    assert sorted(os.listdir(tmp_path)) == ["blocker"]


def test_write_files_refuses_a_directory_under_a_file(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(UsageError, match="cannot create directory"):
        write_files({tmp_path / "f" / "d" / "a.txt": "a"}, directories=[tmp_path / "f" / "d"])


@pytest.mark.parametrize("where", ["while writing the second file", "before the renames"])
def test_an_interrupt_while_writing_leaves_no_temporary_file(tmp_path, monkeypatch, where):
    import vrcal.fileio as fio

    if where == "before the renames":
        def interrupted(_renames):
            raise KeyboardInterrupt
        monkeypatch.setattr(fio, "_commit", interrupted)
    else:
        real, calls = os.chmod, []

        def chmod(*args):
            calls.append(args)
            if len(calls) == 2:
                raise KeyboardInterrupt
            return real(*args)
        monkeypatch.setattr(fio.os, "chmod", chmod)
    with pytest.raises(KeyboardInterrupt):
        write_files({tmp_path / "a": "1", tmp_path / "b": "2", tmp_path / "c": "3"}, directories=[tmp_path / "d"])
    assert os.listdir(tmp_path) == []


def test_output_to_a_fifo_writes_into_it_and_keeps_it(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got = []

    def reader():
        with open(fifo, encoding="utf-8") as fh:
            got.append(fh.read())

    t = threading.Thread(target=reader, daemon=True)
    t.start()
    atomic_write(fifo, "hello\n")
    t.join(timeout=10)
    assert got == ["hello\n"]
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert _no_temporaries(tmp_path)


def test_output_to_a_device_node_writes_into_it_and_keeps_it(tmp_path):
    dev = tmp_path / "null"
    try:
        os.mknod(dev, stat.S_IFCHR | 0o666, os.makedev(1, 3))  # a /dev/null of the test's own
    except PermissionError:
        pytest.skip("making a device node needs root")
    atomic_write(dev, "into the void\n")
    assert stat.S_ISCHR(os.lstat(dev).st_mode)
    assert os.listdir(tmp_path) == ["null"]


def test_output_to_a_symbolic_link_writes_its_target(tmp_path):
    (tmp_path / "real.txt").write_text("old")
    os.symlink("real.txt", tmp_path / "link.txt")
    atomic_write(tmp_path / "link.txt", "new")
    assert os.path.islink(tmp_path / "link.txt") and (tmp_path / "real.txt").read_text() == "new"


def test_an_ordinary_file_is_still_replaced_atomically(tmp_path):
    p = tmp_path / "x.txt"
    p.write_text("old")
    inode = os.stat(p).st_ino
    atomic_write(p, "new")
    assert p.read_text() == "new" and os.stat(p).st_ino != inode and _no_temporaries(tmp_path)


def test_yaml_safe_load_is_untouched():
    """The refusing loader is a subclass: PyYAML's own safe loader keeps its behaviour."""
    assert yaml.safe_load("a: &x 1\nb: *x\n") == {"a": 1, "b": 1}
    assert isinstance(DataError("x"), VrcalError)


def test_the_yaml_shipped_with_vrcal_passes_the_strict_loader():
    """The shipped standards are read with libyaml's fast loader; they must pass the refusals too."""
    from importlib import resources

    from helpers import EXAMPLES

    text = resources.files("vrcal").joinpath("standards.yaml").read_text(encoding="utf-8")
    assert parse_yaml(text, "standards.yaml") == parse_yaml(text, "standards.yaml", trusted=True)
    for path in EXAMPLES.glob("*.yaml"):
        parse_yaml(path.read_text(encoding="utf-8"), str(path))


@pytest.mark.parametrize("text", ["a: &x [1, *x]\n", "a: &x {b: *x}\n", "bodies: &b [*b]\n"])
def test_a_recursive_alias_is_refused(text):
    """An alias inside the value it names loaded as a self-containing list or mapping ([1, [...]]), which any
    code walking it recurses into forever; refused with its line like the other aliases vrcal does not take."""
    with pytest.raises(DataError, match=r"alias \*\w is inside the value it names \(a recursive alias\)"):
        parse_yaml(text, "x.yaml")
