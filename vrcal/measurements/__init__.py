"""Measurements: real records read into one of three kinds of data.

One reader module per layout (``trajectory``, ``tracker``, ``pixels_ref``, ``impacts``,
``apexes``) behind one entry point, as pvlib keeps one ``iotools`` module per data source;
``table`` reads text tables for all of them, ``cleanup`` holds the clean-up equations,
``types`` the result classes. Nothing here fits or simulates.

One entry point, :func:`read_measurement`, auto-detects the layout of a file (or takes
it from ``fmt``, one of the keys of :data:`FORMATS`) and returns one of three frozen
dataclasses: :class:`Trajectory`, :class:`ImpactTimes` or :class:`ApexHeights`.

Formats (``FORMATS``; ``vrcal ... --format NAME``)
--------------------------------------------------
``trajectory``
    a header row naming a time column (``t``, ``time``) and a height column ``y``
    (``x`` optional), then one row per sample. Units may follow a name in brackets:
    ``t (s)``, ``t [ms]``, ``y (cm)``, ``y (px)``. Without a time column the sample
    times come from ``fs_hz``. ``vrcal simulate`` writes ``t,y`` (s, m).
``tracker``
    a data export of Tracker (physlets.org/tracker, *File > Export > Data*): line 1
    is the track name with spaces turned into ``_`` (``mass_A``), line 2 the column
    names (``t``, ``x``, ``y``, ...), then numbers such as ``1.245986911E-1``, all
    joined by the chosen delimiter (tab, space, comma or semicolon; a decimal comma
    when Tracker runs in such a locale). A ``#multi:`` export (several tracks) uses
    the columns of the track whose ``y`` spans the most (the ball's). Rows of frames that were not marked (empty ``y``)
    are skipped.
``pixels-ref``
    a reference-length pixel file: line 1 ``LENGTH_M;LENGTH_PX`` (a reference length
    in metres and the pixels it spans), then ``y_img;x_img;`` per video frame, image
    y axis pointing down. Needs ``fs_hz`` (the frame rate is not in the file).
``impacts``
    impact times, e.g. a phyphox *Acoustic Stopwatch* / *(In)elastic collision* CSV
    export: a (possibly quoted) header such as ``"Event time (s)"``, separators comma,
    semicolon or tab, decimal point or comma, scientific notation. With several
    columns the time column is picked by its name. ``vrcal simulate`` writes ``t``.
``apexes``
    apex heights ``bounce,h``: bounce 0 is the drop height [m].

Conversions and clean-up
------------------------
* Heights: ``y_m = y * scale`` (``scale_m_per_px``, or the unit in the header), and
  ``y_m = -y * scale`` when ``y_down`` (image rows grow downwards; forced for
  ``pixels-ref``). No offset is added: the heights are relative to whatever origin
  the file uses (for an image, its top edge); the fitter's free offset absorbs it.
* The still segment before release is detected (:func:`cleanup.detect_release_index`) and
  kept; a tracker's glitches (:func:`cleanup.tracker_glitches`) and duplicated video frames
  (:func:`cleanup.find_duplicated_frames`) are dropped.
* Impact times are screened for missed impacts and echoes
  (:func:`cleanup.detect_impact_anomalies`); only the clean prefix is kept for fitting.

Errors are :class:`vrcal.errors.DataError` with a one-line message
``FILE:LINE: what is wrong``; an unknown format or a missing option is a
:class:`vrcal.errors.UsageError`. Nothing is ever written by this module.
"""

from __future__ import annotations

from vrcal.measurements.cleanup import (
    detect_impact_anomalies,
    detect_release_index,
    find_duplicated_frames,
    impact_chains,
    prominent_minima,
)
from vrcal.measurements.reader import (
    FORMATS,
    READER_OPTIONS,
    Format,
    detect_format,
    format_help,
    read_measurement,
    read_measurements,
)
from vrcal.measurements.types import ApexHeights, ImpactTimes, Runs, Trajectory

__all__ = [
    "FORMATS", "READER_OPTIONS", "ApexHeights", "Format", "ImpactTimes", "Runs", "Trajectory", "detect_format",
    "detect_impact_anomalies", "detect_release_index", "find_duplicated_frames", "format_help", "impact_chains",
    "prominent_minima", "read_measurement", "read_measurements",
]
