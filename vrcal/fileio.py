"""Writing output files atomically: a temporary file beside the target, renamed at the end.

A failed run leaves no partial output file behind.
"""

from __future__ import annotations

import os
from pathlib import Path

import yaml

from vrcal.errors import DataError, UsageError


def atomic_write(path, data):
    """Write ``data`` (str or bytes) to ``path`` through a temporary file and a rename.

    Raises
    ------
    UsageError
        when the directory does not exist or cannot be written (exit status 2).
    """
    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise UsageError(f"cannot write '{path}': it is a directory")
    if not directory.is_dir():
        raise UsageError(f"cannot write '{path}': directory '{directory}' does not exist")
    import tempfile

    mode = "wb" if isinstance(data, (bytes, bytearray)) else "w"
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
    except OSError as exc:
        raise UsageError(f"cannot write '{path}': {exc.strerror or exc}") from None
    try:
        with os.fdopen(fd, mode, **({} if mode == "wb" else {"encoding": "utf-8", "newline": "\n"})) as fh:
            fh.write(data)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the file the usual mode
        os.replace(tmp, path)
    except OSError as exc:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise UsageError(f"cannot write '{path}': {exc.strerror or exc}") from None
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_savefig(fig, path, **kwargs):
    """Save a matplotlib figure atomically (format from the path's suffix)."""
    import io

    buf = io.BytesIO()
    fmt = Path(path).suffix.lstrip(".") or "png"
    fig.savefig(buf, format=fmt, **kwargs)
    atomic_write(path, buf.getvalue())


def dumps(data, fmt):
    """Serialise a nested dict to 'json' or 'yaml' text with sorted keys (repeatable output)."""
    if fmt == "json":
        import json

        return json.dumps(data, indent=2, sort_keys=True) + "\n"
    if fmt == "yaml":
        return yaml.safe_dump(data, sort_keys=True, default_flow_style=False)
    raise UsageError(f"unknown format '{fmt}' (known: json, yaml)")


#: yaml's safe loader; libyaml's C version (same results, several times faster) when PyYAML has it.
_SAFE_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def parse_yaml(text, where):
    """The document in YAML ``text`` (safe loader only); ``where`` names it in errors.

    Raises
    ------
    DataError
        malformed YAML, with the line when the parser knows it (``where:LINE: ...``)
    """
    try:
        return yaml.load(text, Loader=_SAFE_LOADER)  # noqa: S506 - a safe loader (libyaml's when installed)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = f":{mark.line + 1}" if mark is not None else ""
        raise DataError(f"{where}{line}: malformed YAML: {exc.problem or exc.context}") from None
    except yaml.YAMLError as exc:
        raise DataError(f"{where}: malformed YAML: {exc}") from None


def read_yaml(path, what):
    """The YAML document in the file ``path``; ``what`` names the kind of file in errors.

    Raises
    ------
    UsageError
        the file does not exist (exit status 2)
    DataError
        the file cannot be read, is not UTF-8 text, or is malformed YAML (exit status 1)
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise UsageError(f"{path}: no such {what} file") from None
    except OSError as exc:
        raise DataError(f"{path}: cannot read {what} file: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise DataError(f"{path}: not a UTF-8 text file") from None
    return parse_yaml(text, str(path))
