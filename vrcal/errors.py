"""Exceptions that the command line turns into a one-line message and an exit status.

``UsageError`` (exit 2): the user asked for something that cannot be done as asked
(unknown ball, K <= 0, an option out of range).
``DataError`` (exit 1): a file or table holds something wrong (malformed YAML, h > H,
a missing field, a measurement file that cannot be read).
:func:`unit_hint` names the likely unit slip of a value out of range, for those messages;
:func:`install_hint` how to install an optional package.
"""

import math


class VrcalError(Exception):
    """Base class of every error vrcal reports to its user."""

    exit_code = 1


class UsageError(VrcalError, ValueError):
    """The request cannot be carried out as asked; exit status 2."""

    exit_code = 2


class DataError(VrcalError, ValueError):
    """A file or table holds something wrong; exit status 1."""

    exit_code = 1


class EngineUnavailable(VrcalError, RuntimeError):
    """An optional physics engine is not installed; the message names the package."""

    exit_code = 1


def install_hint(package, extra):
    """How to install an optional ``package`` that vrcal's ``extra`` holds: the package itself, or the extra
    from vrcal's folder, as the README installs it (``'vrcal[extra]'`` would ask a package index for vrcal)."""
    return f"pip install {package} (or, in vrcal's folder, pip install '.[{extra}]')"


def unit_hint(value, maximum, option, unit, small_unit, factor):
    """The likely unit slip of a value above ``maximum``, for a refusal: ``'; --dt is in s: 2 ms =
    0.002'`` when ``value / factor`` lies in range (``small_unit`` typed for ``unit``), else ''.

    Parameters
    ----------
    value : float or str
        what was given
    maximum : float
        the largest value accepted, in ``unit``
    option, unit, small_unit : str
        the option's name, its unit, and the smaller unit it was probably given in
    factor : float
        ``small_unit`` per ``unit`` (1000 for ms per s, 100 for cm per m)
    """
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
        return ""
    if math.isfinite(x) and maximum < x <= factor * maximum:
        return f"; {option} is in {unit}: {x:g} {small_unit} = {x / factor:g} {unit}"
    return ""


def closest_name(value, names, cutoff=0.6):
    """The name of ``names`` that ``value`` was probably meant to be (a typo: 'mujuco' -> 'mujoco'), or
    None: the one offer of every "did you mean" (balls, effects, choices of an option)."""
    import difflib

    close = difflib.get_close_matches(str(value), [str(n) for n in names], n=1, cutoff=cutoff)
    return close[0] if close else None
