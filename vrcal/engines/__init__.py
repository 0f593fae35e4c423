"""Physics engines: export calibrated restitution to real engines and verify it there.

Registry
--------
:data:`ENGINES` maps an engine name to an :class:`Engine` entry: the module that writes its
file, the file format, whether vrcal can run it (``runs``), the package that provides it and
the install hint used in :class:`vrcal.errors.EngineUnavailable`, the name people know it by
(``label``), the engine whose runtime checks its file (``runs_in``: Gazebo's SDF runs in ODE, so
an export checks it in libode; :func:`runtime` gives that entry), whether its file holds one
constant epsilon (``one_epsilon``: no speed law) and why vrcal does not run it (``not_run``). ``mujoco`` and ``bullet``
come from PyPI (the optional extra ``engines``); ``ode`` is the system's C library (Debian
``libode8``) loaded with ctypes by :mod:`vrcal.engines.ode_ctypes`; ``gazebo`` and ``tables``
(PhysX/Unity/Box2D) are exported only, no runtime is needed or used.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

from vrcal.errors import EngineUnavailable, UsageError, install_hint


@dataclass(frozen=True)
class Engine:
    """One entry of the engine registry."""

    name: str
    module: str
    fmt: str            # "xml", "json", "sdf", "text"
    runs: bool          # vrcal can run the drop test in it
    package: str        # what provides the runtime
    install: str        # how to install it
    default_dt_s: float
    description: str
    max_steps: int = 0  # most engine steps of one drop test (0: vrcal does not run it)
    label: str = ""     # how people name it (notes, messages)
    runs_in: str = ""   # the engine whose runtime checks its file ("": none)
    one_epsilon: bool = False  # its file holds one constant epsilon (no speed law)
    not_run: str = ""   # why vrcal does not run it, for the refusal of verify (after a '; ')


ENGINES = {
    "mujoco": Engine("mujoco", "vrcal.engines.mujoco", "xml", True, "mujoco (PyPI)",
                     install_hint("mujoco", "engines"), 2e-3,
                     "MJCF, contact calibrated in MuJoCo", 4_000_000, label="MuJoCo", runs_in="mujoco"),
    "ode": Engine("ode", "vrcal.engines.ode", "json", True, "libode8 (Debian)",
                  "apt-get install libode8", 1e-3,
                  "bounce, world settings (JSON, C)", 1_000_000, label="ODE", runs_in="ode"),
    "bullet": Engine("bullet", "vrcal.engines.bullet", "json", True, "pybullet (PyPI)",
                     install_hint("pybullet", "engines"), 1.0 / 240.0,
                     "changeDynamics etc. (JSON, Python)", 400_000, label="PyBullet", runs_in="bullet"),
    "gazebo": Engine("gazebo", "vrcal.engines.gazebo", "sdf", False, "none (export only)", "", 1e-3,
                     "SDF 1.7 world (ODE physics)", label="Gazebo", runs_in="ode", one_epsilon=True,
                     not_run="vrcal verify --engine gazebo --file WORLD.sdf runs an SDF world in libode, its "
                             "surfaces combined as Gazebo classic does"),
    "tables": Engine("tables", "vrcal.engines.tables", "text", False, "none (export only)", "", 1e-3,
                     "PhysX, Unity, Box2D values", label="PhysX, Unity and Box2D", one_epsilon=True),
}


def default_steps_text():
    """The engines' default time steps as ``--dt``'s help names them: ``mujoco 0.002, ode 0.001, bullet
    1/240, gazebo 0.001`` (a step that is a whole fraction of a second with more digits, such as PyBullet's
    240 Hz, as that fraction); from :data:`ENGINES`, for every engine with a step (not tables)."""
    def text(dt_s):
        plain, hz = f"{dt_s:g}", round(1.0 / dt_s)
        return f"1/{hz}" if len(plain) > 6 and abs(hz * dt_s - 1.0) < 1e-9 else plain

    return ", ".join(f"{name} {text(e.default_dt_s)}" for name, e in ENGINES.items() if name != "tables")


def get_engine(name):
    """The registry entry of ``name``; :class:`UsageError` naming the known engines otherwise."""
    key = str(name).strip().lower()
    aliases = {"pybullet": "bullet", "physx": "tables", "unity": "tables", "box2d": "tables", "sdf": "gazebo"}
    key = aliases.get(key, key)
    if key not in ENGINES:
        raise UsageError(f"unknown engine '{name}' (known: {', '.join(ENGINES)})")
    return ENGINES[key]


def load(name):
    """Import the module of engine ``name``."""
    return importlib.import_module(get_engine(name).module)


def runtime(name):
    """The registry entry of the engine whose runtime checks ``name``'s file (Gazebo: ODE); UsageError
    for an engine whose file no runtime checks (tables)."""
    engine = get_engine(name)
    if not engine.runs_in:
        raise UsageError(f"vrcal runs no engine for {engine.name}'s file")
    return get_engine(engine.runs_in)


def require_runtime(name):
    """Check that vrcal can run engine ``name`` here; returns its version string.

    Raises
    ------
    UsageError
        the engine has no runtime in vrcal (gazebo, tables)
    EngineUnavailable
        the engine is not installed (the message names the package)
    """
    engine = get_engine(name)
    if not engine.runs:
        runnable = ", ".join(k for k, e in ENGINES.items() if e.runs)
        why = f"; {engine.not_run}" if engine.not_run else ""
        raise UsageError(f"vrcal cannot run {engine.name} (export only); verify works with: {runnable}{why}")
    return load(engine.name).version()


def availability():
    """``{engine: version string or the EngineUnavailable message}`` for every runnable engine."""
    out = {}
    for name, engine in ENGINES.items():
        if engine.runs:
            try:
                out[name] = require_runtime(name)
            except EngineUnavailable as exc:
                out[name] = f"unavailable: {exc}"
    return out


def engine_table():
    """An aligned text table of the registry with what is installed here (for ``vrcal engines``)."""
    from vrcal.textout import table

    found = availability()
    rows = []
    for name, e in ENGINES.items():
        status = found.get(name, "export only")
        if status.startswith("unavailable"):
            status = "not installed (see below)"
        dt = f"{e.default_dt_s:.4g}" if name != "tables" else "-"
        rows.append([name, e.fmt, dt, status[:30], e.description])
    text = table(rows, ["engine", "file", "default dt s", "runs here", "provides"], align="llrll")
    missing = [f"{n}: {found[n][len('unavailable: '):]}" for n in ENGINES if found.get(n, "").startswith("unavailable")]
    return text + "".join(line + "\n" for line in missing)
