"""What the readers return: one frozen dataclass per kind of measurement.

:class:`Trajectory` (heights against time), :class:`ImpactTimes` (the times of the floor
impacts) and :class:`ApexHeights` (the apex height of each bounce). ``kind`` names the kind;
the fitter (:mod:`vrcal.discovery`) and the synthetic generator (:mod:`vrcal.drop.synthetic`)
use the same classes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Trajectory:
    """Heights of a tracked point of the ball against time.

    Attributes
    ----------
    t_s : ndarray
        sample times [s], strictly increasing (duplicated frames removed)
    y_m : ndarray
        height of the tracked point [m], up-positive, origin as in the file
    source : str
        the file it was read from
    notes : tuple of str
        human-readable remarks (format, conversions, dropped frames, release)
    release_index : int
        index (into ``t_s``) of the first sample after the still segment; 0 when none
        was detected. The still samples are kept: the fitter models the hold.
    """

    t_s: np.ndarray
    y_m: np.ndarray
    source: str
    notes: tuple = ()
    release_index: int = 0
    kind: str = "trajectory"


@dataclass(frozen=True)
class ImpactTimes:
    """Times of the floor impacts of one drop (e.g. from the sound of the bounces).

    Attributes
    ----------
    t_s : ndarray
        impact times kept for fitting [s], strictly increasing: the clean prefix before
        the first detected anomaly
    source : str
        the file it was read from
    notes : tuple of str
        human-readable remarks
    rejected : tuple
        ``((index, time_s, reason), ...)`` for every impact not kept; ``index`` counts
        the file's impacts from 0
    """

    t_s: np.ndarray
    source: str
    notes: tuple = ()
    rejected: tuple = ()
    kind: str = "impacts"


@dataclass(frozen=True)
class ApexHeights:
    """Apex heights of successive bounces; bounce 0 is the drop height.

    Attributes
    ----------
    bounce : ndarray of int
        bounce number, strictly increasing (0 = release)
    h_m : ndarray
        apex height [m]
    source : str
        the file it was read from
    notes : tuple of str
        human-readable remarks
    """

    bounce: np.ndarray
    h_m: np.ndarray
    source: str
    notes: tuple = ()
    kind: str = "apexes"
