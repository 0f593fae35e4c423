"""Writing output files atomically: a temporary file beside the target, renamed at the end.

A failed run leaves no partial output file behind.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
import stat
from pathlib import Path

import yaml

from vrcal.errors import DataError, UsageError
from vrcal.textout import ASCII_FALLBACK, printable_name

#: Largest YAML file (standards, scene) read [bytes]; PyYAML's safe loader reads about 0.3 MB/s.
MAX_YAML_BYTES = 1 << 20
#: Deepest nesting of lists and mappings in a YAML file.
MAX_YAML_DEPTH = 50
#: Most values the aliases (``*name``) of one YAML file may expand to, counted with the values they
#: repeat: anchors and merge keys copy a ball's settings, a "billion laughs" is refused at once.
MAX_YAML_ALIAS_VALUES = 10_000
#: Largest measurement text file read (a 10**6-row trajectory is about 30 MB) [bytes].
MAX_TEXT_BYTES = 256 << 20


def read_bytes_bounded(path, limit_bytes, what="file"):
    """The bytes of the file ``path``, refusing one larger than ``limit_bytes`` (or endless, as /dev/zero).

    At most ``limit_bytes + 1`` bytes are read, so a huge or endless file costs no more than that.
    ``OSError`` (missing, a directory, no permission) reaches the caller unchanged.

    Raises
    ------
    DataError
        the file holds more than ``limit_bytes`` bytes; the message gives the limit
    """
    with open(path, "rb") as fh:
        data = fh.read(limit_bytes + 1)
    if len(data) > limit_bytes:
        raise DataError(f"{path}: larger than the limit of {_size(limit_bytes)} for a {what} file")
    return data


def _size(n_bytes):
    return f"{n_bytes / 2**20:g} MiB" if n_bytes >= 2**20 else f"{n_bytes / 2**10:g} KiB"


def atomic_write(path, data):
    """Write ``data`` (str or bytes) to ``path`` through a temporary file and a rename.

    A path that exists and is not a regular file (a device such as /dev/null, a FIFO) is
    written into, never replaced; a symbolic link is followed (its target is written).

    Raises
    ------
    UsageError
        when the directory does not exist or cannot be written (exit status 2).
    """
    write_files({path: data})


def write_files(files, directories=()):
    """Write every file of ``files`` (path -> str or bytes), or none of them.

    Every regular file is first written to a temporary file beside it (with the permissions of the file it
    replaces, else 0666 less the umask); only when all of them
    are written are they renamed into place (with SIGINT and SIGTERM held back for the
    renames). On any failure, or an interrupt, the temporary files and the ``directories``
    this call created are removed, so a failed run leaves nothing behind. Paths that exist
    and are not regular files (devices, FIFOs) are written into, never replaced; symbolic
    links are followed.

    Parameters
    ----------
    files : dict
        path -> data, written in this order
    directories : iterable of paths
        directories to create first (with their parents) when missing

    Raises
    ------
    UsageError
        a directory cannot be created, or a file cannot be written (exit status 2)
    """
    created, staged = [], []
    try:
        for d in directories:
            created += _make_directory(Path(d))
        for path, data in files.items():
            _stage(Path(path), data, staged)
        for target, tmp, data in staged:
            if tmp is None:
                _write_into(target, data)
        _commit([(target, tmp) for target, tmp, _ in staged if tmp is not None])
        created = []
    finally:
        for _target, tmp, _data in staged:
            if tmp is not None and os.path.exists(tmp):
                os.unlink(tmp)
        for d in reversed(created):
            try:
                d.rmdir()
            except OSError:
                pass


#: How text files are written: UTF-8, Unix newlines; an undecodable byte of a file name quoted in the text
#: (a lone surrogate, which UTF-8 cannot hold) written ``\\xNN`` (:data:`vrcal.textout.ASCII_FALLBACK`).
_TEXT_FILE = {"encoding": "utf-8", "newline": "\n", "errors": ASCII_FALLBACK}


def _make_directory(d):
    """Create ``d`` and missing parents; the directories created, outermost first."""
    if d.is_dir():
        return []
    if d.exists():
        raise UsageError(f"cannot create directory '{d}': a file of that name exists")
    missing = [p for p in [d, *d.parents] if not p.exists()][::-1]
    made = []
    try:
        for p in missing:
            p.mkdir()
            made.append(p)
    except OSError as exc:
        for p in reversed(made):
            p.rmdir()
        raise UsageError(f"cannot create directory '{d}': {exc.strerror or exc}") from None
    return made


def check_writable(path):
    """Refuse up front (UsageError, one line) an output path that cannot be written.

    For a command that works for seconds before it writes: a directory given as the file, a
    missing directory, or one without write permission is said before the work, in the words
    the write itself would use.
    """
    path = Path(path)
    if path.is_dir():
        raise UsageError(f"cannot write '{path}': it is a directory")
    if path.exists() and not path.is_file():
        return                                     # a device or FIFO: written into
    directory = path.parent if str(path.parent) else Path(".")
    if not directory.is_dir():
        raise UsageError(f"cannot write '{path}': directory '{directory}' does not exist")
    if not os.access(directory, os.W_OK | os.X_OK):
        raise UsageError(f"cannot write '{path}': {os.strerror(13)}")


def _stage(path, data, staged):
    """Append (target, temporary file or None, data) to ``staged``; a regular file's data is written now."""
    if path.is_dir():
        raise UsageError(f"cannot write '{path}': it is a directory")
    if path.exists() and not path.is_file():
        staged.append((path, None, data))  # a device or FIFO (or a link to one): written into, never replaced
        return
    if path.is_symlink():
        path = Path(os.path.realpath(path))  # a link to a file: the file is replaced, the link stays
    directory = path.parent if str(path.parent) else Path(".")
    if not directory.is_dir():
        raise UsageError(f"cannot write '{path}': directory '{directory}' does not exist")
    import tempfile

    mode = "wb" if isinstance(data, (bytes, bytearray)) else "w"
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
    except OSError as exc:
        raise UsageError(f"cannot write '{path}': {exc.strerror or exc}") from None
    staged.append((path, tmp, data))  # from here on the caller removes it if anything fails
    try:
        with os.fdopen(fd, mode, **({} if mode == "wb" else _TEXT_FILE)) as fh:
            fh.write(data)
        os.chmod(tmp, _mode_for(path))  # mkstemp makes 0600
    except OSError as exc:
        raise UsageError(f"cannot write '{path}': {exc.strerror or exc}") from None


def _write_into(path, data):
    """Write into an existing device or FIFO (opening a FIFO waits for a reader, as ``cat > fifo`` does)."""
    if stat.S_ISSOCK(os.stat(path).st_mode):
        raise UsageError(f"cannot write '{path}': it is a socket")
    mode = "wb" if isinstance(data, (bytes, bytearray)) else "w"
    try:
        with open(path, mode, **({} if mode == "wb" else _TEXT_FILE)) as fh:
            fh.write(data)
    except OSError as exc:
        raise UsageError(f"cannot write '{path}': {exc.strerror or exc}") from None


def _commit(renames):
    """Rename the temporary files into place with SIGINT/SIGTERM held back (all or none arrive)."""
    held = {signal.SIGINT, signal.SIGTERM}
    try:
        old = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    except (AttributeError, ValueError, OSError):  # pragma: no cover - no signal masks here
        old = None
    try:
        for target, tmp in renames:
            try:
                os.replace(tmp, target)
            except OSError as exc:
                raise UsageError(f"cannot write '{target}': {exc.strerror or exc}") from None
    finally:
        if old is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)


@contextlib.contextmanager
def temporary_beside(path):
    """A temporary path beside ``path`` with the same suffix, for a writer that takes a file name
    (OpenCV picks the container by the suffix): renamed to ``path`` with the mode :func:`write_files`
    gives (the replaced file's, else 0666 less the umask) when the block succeeds, removed when it fails.

    Raises
    ------
    UsageError
        the directory does not exist or cannot be written (exit status 2)
    """
    import tempfile

    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    if not directory.is_dir():
        raise UsageError(f"cannot write '{path}': directory '{directory}' does not exist")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=path.suffix, dir=directory)
    except OSError as exc:
        raise UsageError(f"cannot write '{path}': {exc.strerror or exc}") from None
    os.close(fd)
    try:
        yield tmp
        os.chmod(tmp, _mode_for(path))  # mkstemp makes 0600
        _commit([(path, tmp)])
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _mode_for(path):
    """The permissions a file written to ``path`` gets: those of the file it replaces (``chmod 600`` kept),
    else the usual 0666 less the umask."""
    try:
        return stat.S_IMODE(os.stat(path).st_mode)
    except OSError:
        return 0o666 & ~_umask()


def _umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_savefig(fig, path, **kwargs):
    """Save a matplotlib figure atomically (format from the path's suffix)."""
    atomic_write(path, figure_bytes(fig, Path(path).suffix.lstrip(".") or "png", **kwargs))


#: Metadata matplotlib would stamp into a figure file that changes from run to run or names the
#: software's version (None leaves it out): the same figure is the same bytes every time.
_REPEATABLE_METADATA = {"png": {"Software": None}, "svg": {"Date": None, "Creator": None},
                        "pdf": {"CreationDate": None, "Creator": None, "Producer": None}}


def figure_bytes(fig, fmt="png", **kwargs):
    """A matplotlib figure rendered to bytes in ``fmt`` (``savefig`` keywords pass through), the same bytes
    on every run: no date or version in the metadata (:data:`_REPEATABLE_METADATA`, a caller's ``metadata``
    added), and SVG ids (clip paths) hashed from a fixed salt instead of a random one."""
    import io

    import matplotlib

    kwargs["metadata"] = {**_REPEATABLE_METADATA.get(fmt.lower(), {}), **(kwargs.get("metadata") or {})}
    buf = io.BytesIO()
    with matplotlib.rc_context({"svg.hashsalt": "vrcal"}):
        fig.savefig(buf, format=fmt, **kwargs)
    return buf.getvalue()


def dumps(data, fmt):
    """Serialise a nested dict to 'json' or 'yaml' text with sorted keys (repeatable output).

    Texts (keys and values) are written with :func:`vrcal.textout.printable_name`: a file name that is not
    UTF-8 keeps its undecodable bytes as ``\\xNN``, never a lone surrogate, which strict UTF-8 readers refuse.
    """
    data = _printable(data)
    if fmt == "json":
        import json

        return json.dumps(data, indent=2, sort_keys=True) + "\n"
    if fmt == "yaml":
        return yaml.safe_dump(data, sort_keys=True, default_flow_style=False)
    raise UsageError(f"unknown format '{fmt}' (known: json, yaml)")


def _printable(data):
    """``data`` (nested dicts, lists, tuples) with every text passed through :func:`printable_name`."""
    if isinstance(data, str):
        return printable_name(data)
    if isinstance(data, dict):
        return {_printable(k): _printable(v) for k, v in data.items()}
    if isinstance(data, (list, tuple)):
        return [_printable(v) for v in data]
    return data


class _Refused(yaml.MarkedYAMLError):
    """Valid YAML that vrcal refuses (aliases repeating too much, a duplicate key, too deep a nesting)."""


class BoundedSafeLoader(yaml.SafeLoader):
    """PyYAML's safe loader, refusing what could bomb it or silently lose data.

    * aliases (``*name``, also in merge keys ``<<: *name``): allowed as long as all of them together
      repeat at most :data:`MAX_YAML_ALIAS_VALUES` values (scalars, lists and mappings, counted as
      expanded), so a "billion laughs" (aliases of aliases) is refused before anything expands;
    * nesting deeper than :data:`MAX_YAML_DEPTH` lists or mappings: refused before Python's
      recursion limit is reached;
    * a key given twice in one mapping: refused (PyYAML keeps the last one silently);
    * an integer too long for Python (over 4300 digits) or a malformed date: a YAML error,
      not a ``ValueError``.

    Every refusal carries the line, like a syntax error.
    """

    def __init__(self, stream):
        super().__init__(stream)
        self._depth = 0
        self._alias_values = 0
        self._sizes = {}

    def _expanded_size(self, node):
        """Values ``node`` stands for when every alias in it is written out (memoised by node)."""
        size = self._sizes.get(id(node))
        if size is None:
            size = 1
            if isinstance(node, yaml.SequenceNode):
                size += sum(self._expanded_size(child) for child in node.value)
            elif isinstance(node, yaml.MappingNode):
                size += sum(self._expanded_size(k) + self._expanded_size(v) for k, v in node.value)
            self._sizes[id(node)] = size
        return size

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            node = super().compose_node(parent, index)
            if node.end_mark is None:   # a list or mapping still being read: the alias is inside its anchor
                raise _Refused(None, None, f"alias *{_short(event.anchor)} is inside the value it names (a "
                                           "recursive alias): write the values out", event.start_mark)
            self._alias_values += self._expanded_size(node)
            if self._alias_values > MAX_YAML_ALIAS_VALUES:
                raise _Refused(None, None, f"alias *{_short(event.anchor)}: the aliases repeat more than "
                                           f"{MAX_YAML_ALIAS_VALUES} values (aliases of aliases: a 'billion "
                                           "laughs'); write the values out", event.start_mark)
            return node
        if self.check_event(yaml.ScalarEvent):
            return super().compose_node(parent, index)
        self._depth += 1  # a list or a mapping
        try:
            if self._depth > MAX_YAML_DEPTH:
                raise _Refused(None, None, f"nested deeper than the limit of {MAX_YAML_DEPTH} levels",
                               self.peek_event().start_mark)
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            seen = {}
            for key_node, _value_node in node.value:
                if not isinstance(key_node, yaml.ScalarNode) or key_node.tag == "tag:yaml.org,2002:merge":
                    continue  # a merge key (<<: *base) is flattened by the base class: its keys may be overridden
                key = self.construct_object(key_node, deep=True)
                try:
                    first = seen.setdefault(key, key_node)
                except TypeError:
                    continue  # unhashable: the base class reports it
                if first is not key_node:
                    raise _Refused(None, None, f"duplicate key {_short(key)!r} (first on line "
                                               f"{first.start_mark.line + 1})", key_node.start_mark)
        return super().construct_mapping(node, deep=deep)

    def construct_object(self, node, deep=False):
        try:
            return super().construct_object(node, deep=deep)
        except (ValueError, OverflowError) as exc:
            raise _Refused(None, None, f"cannot read the value: {exc}", node.start_mark) from None


def _construct_bounded_int(loader, node):
    value = yaml.SafeLoader.construct_yaml_int(loader, node)
    if abs(value) > 1e308:
        raise _Refused(None, None, f"integer of {len(str(abs(value)))} digits: larger than any number vrcal "
                                   "computes with (1e308)", node.start_mark)
    return value


BoundedSafeLoader.add_constructor("tag:yaml.org,2002:int", _construct_bounded_int)
# YAML 1.1 (PyYAML) reads "1e-3" as text; YAML 1.2 and people read it as a number: so do we.
BoundedSafeLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float", re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"))


def _short(value, limit=60):
    """``value`` as text of at most ``limit`` characters (long names in messages)."""
    text = str(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


#: The loader of YAML shipped with vrcal (trusted): libyaml's C safe loader when PyYAML has it (same
#: results, ten times faster; it crashes on very deep nesting, so never for a user's file).
_TRUSTED_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def parse_yaml(text, where, *, trusted=False):
    """The document in YAML ``text`` (:class:`BoundedSafeLoader`); ``where`` names it in errors.

    ``trusted=True`` is for YAML shipped with vrcal (the standards file): libyaml's fast loader,
    without the refusals (a test checks the shipped files pass them).

    Raises
    ------
    DataError
        malformed YAML, aliases that repeat too much, a duplicate key or too deep a nesting, with the line when
        the parser knows it (``where:LINE: ...``)
    """
    try:
        return yaml.load(text, Loader=_TRUSTED_LOADER if trusted else BoundedSafeLoader)  # noqa: S506 - safe
    except _Refused as exc:
        raise DataError(f"{where}:{exc.problem_mark.line + 1}: {exc.problem}") from None
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = f":{mark.line + 1}" if mark is not None else ""
        raise DataError(f"{where}{line}: malformed YAML: {exc.problem or exc.context}") from None
    except yaml.YAMLError as exc:
        raise DataError(f"{where}: malformed YAML: {_short(exc, 200)}") from None


def read_yaml(path, what):
    """The YAML document in the file ``path``; ``what`` names the kind of file in errors.

    The file is read only up to :data:`MAX_YAML_BYTES` (a larger or endless file is refused).

    Raises
    ------
    UsageError
        the file does not exist (exit status 2)
    DataError
        the file cannot be read, is too large, is not UTF-8 text, or is malformed YAML (exit status 1)
    """
    path = Path(path)
    try:
        raw = read_bytes_bounded(path, MAX_YAML_BYTES, what)
    except FileNotFoundError:
        raise UsageError(f"{path}: no such {what} file") from None
    except IsADirectoryError:
        raise DataError(f"{path}: is a directory, not a {what} file") from None
    except OSError as exc:
        raise DataError(f"{path}: cannot read {what} file: {exc.strerror or exc}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise DataError(f"{path}: not a UTF-8 text file") from None
    return parse_yaml(text, str(path))
