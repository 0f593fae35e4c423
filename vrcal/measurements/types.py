"""What the readers return: one frozen dataclass per kind of measurement.

:class:`Trajectory` (heights against time), :class:`ImpactTimes` (the times of the floor
impacts) and :class:`ApexHeights` (the apex height of each bounce). ``kind`` names the kind;
the fitter (:mod:`vrcal.discovery`) and the synthetic generator (:mod:`vrcal.drop.synthetic`)
use the same classes. :class:`Runs` holds several runs of one ball and one kind that are
fitted jointly (a table of drop and rebound heights, several files, or the pieces of one
record around a bounce that does not belong): shared contact, one release state per run.
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
    lines : ndarray of int or None
        the file's line of each sample (None when unknown), for notes that name them
    systematic_m : float
        systematic uncertainty of each height beyond its noise from sample to sample [m], as the
        reader knows it (a video tracker's centre error from blur, compression and shading); 0 when
        the reader knows none. ``vrcal discover`` adds it to the noise it measures, in quadrature
    floor_sd_m : float
        standard uncertainty of the floor level [m] when the reader estimated it (a video's contact
        row from its bounces); 0 when the floor is the file's own zero. A ``height_offset`` within
        what it allows is not named
    """

    t_s: np.ndarray
    y_m: np.ndarray
    source: str
    notes: tuple = ()
    release_index: int = 0
    kind: str = "trajectory"
    lines: np.ndarray = None
    systematic_m: float = 0.0
    floor_sd_m: float = 0.0


@dataclass(frozen=True)
class ImpactTimes:
    """Times of the floor impacts of one drop (e.g. from the sound of the bounces).

    Attributes
    ----------
    t_s : ndarray
        impact times kept for fitting [s], strictly increasing (echoes and events that fit in
        no chain of bounces removed)
    source : str
        the file it was read from
    notes : tuple of str
        human-readable remarks
    rejected : tuple
        ``((index, time_s, reason), ...)`` for every event not kept; ``index`` counts
        the file's events from 0 (the file's event number is index + 1)
    chains : tuple
        ``((start, stop), ...)``: slices of ``t_s`` holding consecutive bounces; a missed
        impact or a bounce that does not belong ends a chain and the next starts after
        it (they may share an event). ``()``: one chain, all of ``t_s``
    events : ndarray of int or None
        the file's event number (1-based) of each kept impact; None: 1, 2, ...
    lines : ndarray of int or None
        the file's line of each kept impact (None when unknown)
    timing_sd_s : float
        standard deviation of each time that the file's own grid sets [s] (times read off a
        video's frames, or printed to 0.01 s: step / sqrt(12),
        :func:`vrcal.measurements.cleanup.time_grid`); 0 when the times have no coarse grid
    instrument_sd_s : float
        standard deviation of each time that the way it was taken sets [s], when the reader knows it and
        the times alone cannot tell it: vrcal's own onsets in a lossless recording
        (:data:`vrcal.measurements.sound.LOSSLESS_TIMING_SD_S`); 0 when unknown (a phone app's times:
        ``vrcal.discovery.ranking.ASSUMED_NOISE``)
    suspect : tuple of str
        what the reader found suspect in the record, each a plausibility warning (verdict "suspect input"):
        a bounce sequence no longer than chance makes among the recording's sound events
        (:func:`vrcal.measurements.sound.chance_chain_lengths`)
    """

    t_s: np.ndarray
    source: str
    notes: tuple = ()
    rejected: tuple = ()
    kind: str = "impacts"
    chains: tuple = ()
    events: np.ndarray = None
    lines: np.ndarray = None
    timing_sd_s: float = 0.0
    instrument_sd_s: float = 0.0
    suspect: tuple = ()


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
    lines : ndarray of int or None
        the file's line of each row (None when unknown)
    resolution_m : float or None
        the step the file wrote the heights to, in metres (0.0254 for whole inches, 0.01 for whole
        centimetres); None when unknown. A height read against a ruler is good to about that step, whatever
        unit it is converted to.
    """

    bounce: np.ndarray
    h_m: np.ndarray
    source: str
    notes: tuple = ()
    kind: str = "apexes"
    lines: np.ndarray = None
    resolution_m: float = None


@dataclass(frozen=True)
class Runs:
    """Several runs of one ball, of one kind, fitted jointly: the contact (epsilon and the
    effects) is shared, every run has its own release state (drop height, release time).

    Attributes
    ----------
    runs : tuple
        the runs (Trajectory, ImpactTimes or ApexHeights, all of one kind)
    source : str
        what they were read from (one file, or several joined by ', ')
    notes : tuple of str
        human-readable remarks about the whole
    labels : tuple of str
        one short label per run ("row 3 (line 5)", "golf_80cm.csv", "bounces 1-4")
    """

    runs: tuple
    source: str
    notes: tuple = ()
    labels: tuple = ()

    @property
    def kind(self):
        """The kind of the runs ("trajectory", "impacts" or "apexes")."""
        return self.runs[0].kind
