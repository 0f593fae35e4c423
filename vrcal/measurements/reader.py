"""The one entry point of :mod:`vrcal.measurements`: :func:`read_measurement`, and the
registry of layouts :data:`FORMATS` (one reader module per layout, as pvlib's ``iotools``).
"""

from __future__ import annotations

import os
import re
from typing import Callable, NamedTuple

from vrcal.errors import UsageError
from vrcal.measurements import apexes, impacts, pixels_ref, sound, tracker, trajectory, video
from vrcal.measurements.table import fail, is_numeric_row, load_text

# --------------------------------------------------------------------------- registry and entry point


class Format(NamedTuple):
    """One file layout: ``detector(text) -> bool``, ``parser(text, **options) -> result``.

    A *recording* (``recording=True``: sound, video) is binary: ``detector(head, path)`` gets
    the file's first 64 bytes and its path, ``parser(path, **options)`` the path and every option.
    """

    detector: Callable
    parser: Callable
    description: str
    recording: bool = False


#: Known layouts, in auto-detection order (the first detector that accepts a file wins).
FORMATS = {
    "pixels-ref": Format(pixels_ref.detect, pixels_ref.parse,
                         "reference-length pixel file: line 1 'LENGTH_M;LENGTH_PX', then 'y_img;x_img;' per frame "
                         "(image y down; needs --fs)"),
    "tracker": Format(tracker.detect, tracker.parse,
                      "Tracker data export: line 1 the track name (mass_A), then columns t, x, y "
                      "(tab, space, comma or semicolon)"),
    "apexes": Format(apexes.detect, apexes.parse, "apex heights: header 'bounce,h' (bounce 0 = drop height, m)"),
    "trajectory": Format(trajectory.detect, trajectory.parse,
                         "trajectory: header 't,y' (s, m; x optional; units like 'y (cm)', 'y (px)' + --scale)"),
    "impacts": Format(impacts.detect, impacts.parse,
                      "impact times: a time column ('t', 'time', \"Event time (s)\"), e.g. a phyphox export"),
    "sound": Format(sound.detect, sound.parse,
                    "a sound recording (WAV; m4a, mp3, ogg, flac with vrcal[audio]): the impact times", recording=True),
    "video": Format(video.detect, video.parse,
                    "a video (mp4, mov, avi, mkv; needs vrcal[video]): the ball's trajectory, scale from its "
                    "diameter", recording=True),
}


def format_help():
    """One line per format, for ``--format`` help texts."""
    return "; ".join(f"{name}: {fmt.description}" for name, fmt in FORMATS.items())


def detect_format(path):
    """Name of the first format in :data:`FORMATS` whose detector accepts the file."""
    name = _detect_recording(path)
    if name is not None:
        return name
    text = load_text(path)
    return _detect(text)


def _detect_recording(path):
    """The recording format (sound, video) a file's first bytes or its name show, or None."""
    try:
        if os.path.exists(path) and not os.path.isfile(path):
            head = b""  # a FIFO or a device is read once, by load_text: no peeking (only the name tells)
        else:
            with open(path, "rb") as fh:
                head = fh.read(64)
    except OSError:
        return None  # load_text reports it
    for name, fmt in FORMATS.items():
        if fmt.recording and fmt.detector(head, str(path)):
            return name
    return None


def _detect(text):
    for name, fmt in FORMATS.items():
        if not fmt.recording and fmt.detector(text):
            return name
    no, line = text.lines[0]
    cells = [c for c in re.split(r"[,;\t]", line) if c.strip()]
    if is_numeric_row(cells):
        fail(text.path, no, "no header row: the first line holds numbers; name the columns "
              "(e.g. 't,y', 't', 'bounce,h')")
    fail(text.path, no, f"cannot tell the layout from the header {line.strip()!r} "
          f"(known formats: {', '.join(FORMATS)}; see --format)")


def read_measurement(path, fmt=None, *, scale_m_per_px=None, y_down=False, fs_hz=None, **recording):
    """Read a measurement file into a Trajectory, ImpactTimes or ApexHeights.

    Parameters
    ----------
    path : str or Path
        the file to read
    fmt : str or None
        a key of :data:`FORMATS`; None detects it from the file
    scale_m_per_px : float or None
        metres per unit of the file's position column (pixels); overrides the header
        unit and the reference line of a ``pixels-ref`` file [m/px]
    y_down : bool
        the file's y axis points down (image rows): height = -y * scale
    fs_hz : float or None
        sampling (frame) rate for files without a time column [Hz]; for a video, the frame
        rate overriding the container's time stamps (a slow-motion video)
    **recording :
        options of the recording readers, ignored by the text layouts: ``diameter_m``
        (video: the ball's diameter [m], which gives the scale), ``roi``, ``color``
        (:func:`vrcal.measurements.video.track_video`), ``progress`` (a callable
        ``progress(fraction, message)``)

    Returns
    -------
    Trajectory or ImpactTimes or ApexHeights
        ``.kind`` is "trajectory", "impacts" or "apexes".

    Raises
    ------
    DataError
        "FILE:LINE: what is wrong" for an unreadable, empty, binary or malformed file.
    UsageError
        an unknown ``fmt`` (the message names the known ones), a missing ``fs_hz`` or
        ``scale_m_per_px`` that the file needs.
    """
    if fmt is not None and fmt not in FORMATS:
        raise UsageError(f"unknown measurement format '{fmt}' (known: {', '.join(FORMATS)})")
    name = fmt or _detect_recording(path)
    if name is not None and FORMATS[name].recording:
        return FORMATS[name].parser(str(path), scale_m_per_px=scale_m_per_px, fs_hz=fs_hz, **recording)
    text = load_text(path)
    name = name or _detect(text)
    return FORMATS[name].parser(text, scale_m_per_px=scale_m_per_px, y_down=y_down, fs_hz=fs_hz)
