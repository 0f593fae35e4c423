"""Sound recordings of a drop (a phone's WAV, or another container through PyAV): the impact times.

This module owns reading audio files into samples (:func:`read_audio`), finding the impact
onsets in them (:func:`impact_onsets`), keeping only the events that fit a bouncing ball
(:func:`bounce_sequence`), and the ``sound`` reader of :data:`vrcal.measurements.FORMATS`
(:func:`parse`), which returns :class:`~vrcal.measurements.types.ImpactTimes`.

How an impact is found
----------------------
1. **Band.** Every channel is high-passed (4th-order Butterworth, 1 kHz, causal): mains hum
   (50/60 Hz and its low harmonics), footsteps and most of a voice's energy are removed,
   the broadband click of an impact is kept. A steady tone in that band (a whistle, a machine's
   whine: a line of the spectrum that stays, :func:`steady_tones`) is stopped too (causal band-stops):
   it would lift the envelope's background and hide the impacts under it.
2. **Candidates.** The envelope ``e(t)`` is the RMS of the filtered signal over 0.25 ms
   (channels summed in energy). A candidate is a peak of the *rise* ``e(t) / (b(t) + n)``,
   where ``b(t)`` is the mean envelope 1-6 ms earlier and ``n`` the noise level (the
   median envelope), above :data:`RISE` and with ``e`` above :data:`SNR` times the noise:
   a new transient, not the ringing or a room echo arriving while the impact still rings.
3. **Onset.** Each candidate's onset is the change point of the filtered signal's variance
   (the AIC picker of seismology, Maeda 1985: minimise ``k ln var(x[:k]) + (N-k) ln
   var(x[k:])`` over a window from 6 ms before to 0.5 ms after the envelope's rise),
   refined between samples by a parabola through the minimum. It does not depend on the
   impact's loudness (a threshold crossing does: a quiet impact crosses it later) nor on
   clipping (which flattens the peak, not the start). A lossy codec (AAC, MP3, Vorbis, Opus)
   spreads each impact's quantisation noise over its transform block, up to a few ms before
   the impact (pre-echo, 10-35 dB over the noise): there the onset is the impact's own start,
   the later change point where the energy jumps :data:`PRE_ECHO_JUMP_DB` over the pre-echo. A phone's
   noise gate does the opposite in lossless audio: it lets an impact's start through at a reduced gain and
   opens later, a gain ramping up; the start, where the sound rose :data:`GATE_STEP_DB` from the noise, is
   then the onset (:func:`_earlier_start`). No stretch's energy is taken below the samples' rounding (a
   gate's exact zeros).
4. **Physics.** A bouncing ball's impacts fall on a geometric-like sequence of intervals
   (``dt_{i+1} ~ r dt_i``, r ~ epsilon). :func:`bounce_sequence` keeps the longest chain of
   candidates whose successive interval ratios agree (within :data:`RATIO_TOLERANCE`, the
   ratio tracking slow changes) and whose loudness does not jump up; claps, words, echoes
   and other noises that do not fit are rejected, each with a reason. The chain's first event
   is judged on its own against the later bounces, with the timing noise and their scatter
   (:func:`vrcal.measurements.cleanup.leading_intruder`): a clap just before the release
   fits the 12 % window but not the 0.2 ms timing of a bounce sequence.
5. **The quiet end.** After the chain's last impact, the next one is searched for only in a
   window around its predicted time (:func:`extend_chain`): there noise alone crosses a much
   lower threshold (about 2.7 times the noise, :func:`window_threshold`) only once in
   1/:data:`WINDOW_FALSE_ALARM` windows, so quiet impacts under the whole file's threshold
   are found, timed like the others. Behind a closed noise gate (exact zeros between the sounds, the noise
   level that of the open gate) a sound is judged over the gated floor, or over the noise if it opens the
   gate. The chain stops at the first window with nothing over that threshold: the bounces after it
   are below the noise and are left out (a note gives the time the next one was expected), not guessed.

The impact times kept are then screened like any impact-times file
(:func:`vrcal.measurements.cleanup.detect_impact_anomalies`).
"""

from __future__ import annotations

import bisect
import math
import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np

from vrcal.errors import DataError, UsageError, install_hint
from vrcal.measurements.cleanup import (
    NOT_A_DROP,
    NOT_AN_IMPACT,
    PULSE_PERIODS_S,
    detect_impact_anomalies,
    leading_intruder,
    no_recorded_drop,
    steady_beat,
    voice_pulses,
)
from vrcal.measurements.types import ImpactTimes

#: File name endings read as sound (other than WAV they need the optional PyAV).
SOUND_EXTENSIONS = (".wav", ".wave", ".m4a", ".aac", ".mp3", ".ogg", ".oga", ".opus", ".flac", ".3gp", ".amr",
                    ".caf", ".aif", ".aiff", ".wma", ".webm")

#: Extensions of MP4 files that hold sound only (a phone's ``.m4a`` may carry the brand ``isom``, ``mp42``).
AUDIO_ONLY_EXTENSIONS = (".m4a", ".m4b", ".aac")

#: One-line hint when a compressed container needs the optional extra.
AUDIO_HINT = f"reading this sound file needs PyAV: {install_hint('av', 'audio')}, or save the recording as WAV"

HIGHPASS_HZ = 1000.0     #: high-pass corner of the onset band [Hz]
ENVELOPE_S = 2.5e-4      #: RMS window of the envelope [s]
RISE = 4.0               #: a candidate's envelope is this many times the level 1-6 ms before it
SNR = 5.0                #: ... and this many times the noise level (the median envelope)
REFRACTORY_S = 4e-3      #: candidates closer than this are one event [s]
RATIO_TOLERANCE = 0.12   #: relative deviation of an interval from the chain's predicted one
MIN_IMPACTS = 3          #: fewest impacts a recording must give
#: Lowest sample rate read [Hz]: telephone sound, the lowest standard rate. The onsets are found above the
#: 1 kHz high-pass (:data:`HIGHPASS_HZ`), where an impact's click lies; below 8 kHz little of that band is left
#: (a phone records at 44.1 or 48 kHz).
MIN_SAMPLE_RATE_HZ = 8000.0
#: What a refusal of a recording with too few impacts adds (a ball on carpet: 43 dB over the noise across the
#: band, 19 dB above 1 kHz, was refused with only "is this a drop recording?").
DULL_IMPACTS = (f"Impacts are heard above {HIGHPASS_HZ / 1000:g} kHz, where a dull one (a carpet, a mat, a soft ball) "
                "is quiet: put the phone on the floor near where the ball lands")
MAX_LISTED = 6           #: rejected events listed one by one in the notes
WINDOW_FALSE_ALARM = 1e-8  #: chance that noise alone crosses the threshold of one predicted-impact window
PRE_ECHO_S = 6e-3        #: longest span a lossy codec smears an impact's noise before it (a 256-sample block) [s]
PRE_ECHO_JUMP_DB = 6.0   #: the impact itself is this much louder than a lossy codec's pre-echo before it [dB]
#: An impact began at an earlier change point when the sound after it is this much louder than before it [dB]
#: (lossless audio, :func:`_earlier_start`: a noise gate opening after the impact's start is a later one)
GATE_STEP_DB = 6.0
#: ... over the level of at least this long a stretch before it [s] (a dip of the ringing 0.3-0.4 ms long at the
#: window's start made the sound after it 6-10 dB "louder" in probes' recordings of a gym, a superball, 8-16 kHz)
GATE_BEFORE_S = 1e-3
#: Timing noise of an onset found in a lossless recording (WAV, FLAC) [s]: synthetic drops with room noise, hum
#: and a reflection are timed to 0.005-0.02 ms, so 0.05 ms holds a real microphone's spread too (the ball's
#: distance to it changes by a few cm between bounces: 0.03 ms per cm). A lossy codec's onsets are worse
#: (0.2-2 ms, by its bit rate) and keep the phone apps' assumed 0.2 ms. A probe's 32 lossless recordings (rooms
#: and stairwells, claps, music, typing, AGC, noise gates, 8-48 kHz) gave 391 impacts timed to 0.030 ms RMS, the
#: worst file's 0.10 ms (a carpet's dull impacts), once a noise gate's impacts were timed at their start
#: (:func:`_earlier_start`: they were 1.8-2.9 ms off).
LOSSLESS_TIMING_SD_S = 5e-5
#: Decoders of lossless audio (PyAV's codec names); every other codec PyAV decodes is taken as lossy.
LOSSLESS_CODECS = ("pcm_", "flac", "alac", "wavpack", "tta", "ape", "mlp", "truehd", "shorten")
AUDIO_BAND_HZ = 20000.0  #: highest frequency a microphone records (the noise band's top) [Hz]


class Audio(NamedTuple):
    """A recording's samples, from :func:`read_audio`."""

    x: np.ndarray     # samples (n, channels), full scale = 1
    fs_hz: float      # sample rate [Hz]
    what: str         # a short description ("WAV, 48 kHz, 2 channels, 16-bit")
    lossy: bool       # coded with loss (AAC, MP3, Vorbis, Opus): each onset is preceded by a pre-echo


@dataclass(frozen=True)
class Onsets:
    """Impact candidates of a recording, from :func:`impact_onsets`.

    Attributes
    ----------
    t_s : ndarray
        onset times [s] from the first sample, increasing
    snr_db : ndarray
        peak envelope of each candidate over the noise level [dB]
    noise_level : float
        the noise level (median envelope of the high-passed signal, full scale = 1)
    """

    t_s: np.ndarray
    snr_db: np.ndarray
    noise_level: float


# --------------------------------------------------------------------------- reading


def detect(head, path):
    """A RIFF/WAVE (or RF64) file, an audio-only MP4/3GP/MOV (brand ``M4A``, or tracks of sound and none of
    video: :func:`mp4_track_kinds`), FLAC, Ogg, MP3, or a sound extension."""
    if head[:4] in (b"RIFF", b"RF64", b"BW64") and head[8:12] == b"WAVE":
        return True
    if head[4:8] == b"ftyp":
        if head[8:11] in (b"M4A", b"M4B"):
            return True
        kinds = mp4_track_kinds(path)
        if kinds is None:   # no track list read: the name decides (.m4a is sound, .mp4 and .3gp video)
            return Path(path).suffix.lower() in AUDIO_ONLY_EXTENSIONS
        return "soun" in kinds and "vide" not in kinds
    if head[:4] in (b"fLaC", b"OggS", b"FORM") or head[:3] == b"ID3" or head[:2] in (b"\xff\xfb", b"\xff\xf3"):
        return True
    return Path(path).suffix.lower() in SOUND_EXTENSIONS and head[4:8] != b"ftyp" and head[:4] != b"RIFF"


def _boxes(fh, start, end):
    """``(type, payload start, box end)`` of the ISO base media (MP4) boxes in bytes ``start .. end`` of ``fh``."""
    pos = start
    while pos + 8 <= end:
        fh.seek(pos)
        head = fh.read(16)
        if len(head) < 8:
            return
        size, kind = int.from_bytes(head[:4], "big"), head[4:8]
        header = 8
        if size == 1:   # a 64-bit size follows the type
            if len(head) < 16:
                return
            size, header = int.from_bytes(head[8:16], "big"), 16
        elif size == 0:  # the box runs to the end
            size = end - pos
        if size < header or pos + size > end:
            return
        yield kind, pos + header, pos + size
        pos += size


def mp4_track_kinds(path):
    """The kinds of the tracks of an MP4, 3GP or QuickTime file (ISO/IEC 14496-12: the handler type of each
    ``moov/trak/mdia/hdlr`` box: ``"soun"`` sound, ``"vide"`` video, ...), or None when the file has no
    track list that can be read (not such a file, or cut short).

    A phone's sound recording (``.m4a``, ``.3gp``) carries the brand ``isom``, ``mp42`` or ``3gp4`` of any
    MP4: only its tracks tell it from a video.

    Returns
    -------
    frozenset of str or None
    """
    try:
        with open(path, "rb") as fh:
            end = os.fstat(fh.fileno()).st_size
            for kind, start, stop in _boxes(fh, 0, end):
                if kind != b"moov":
                    continue
                found = set()
                for trak, a, b in _boxes(fh, start, stop):
                    for mdia, c, d in (_boxes(fh, a, b) if trak == b"trak" else ()):
                        for hdlr, e, f in (_boxes(fh, c, d) if mdia == b"mdia" else ()):
                            if hdlr == b"hdlr" and f - e >= 12:
                                fh.seek(e + 8)   # after version, flags and pre_defined (QuickTime: the component type)
                                found.add(fh.read(4).decode("latin-1"))
                return frozenset(found)
    except OSError:
        return None
    return None


def read_audio(path):
    """Samples of a sound file as floats in [-1, 1], shape (n, channels), and the sample rate.

    WAV (PCM 8/16/24/32-bit, float 32/64, mono or multi-channel) is read with
    :func:`scipy.io.wavfile.read`; any other container (m4a, mp3, ogg, flac, the sound track
    of a video) with PyAV, the optional extra ``audio``.

    Returns
    -------
    Audio
        ``(x, fs_hz, what, lossy)``: samples (n, channels), full scale = 1; sample rate [Hz]; a short
        description (``"WAV, 48 kHz, 2 channels, 16-bit"``); whether the codec is lossy (everything
        PyAV decodes but FLAC, ALAC, PCM and the other :data:`LOSSLESS_CODECS`)

    Raises
    ------
    DataError
        unreadable, corrupt or empty file; EngineUnavailable-like UsageError when PyAV is missing
    """
    path = str(path)
    try:
        with open(path, "rb") as fh:
            head = fh.read(12)
    except IsADirectoryError:
        raise DataError(f"{path}: is a directory, not a recording") from None
    except OSError as exc:
        raise DataError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if head[:4] in (b"RIFF", b"RF64") and head[8:12] == b"WAVE":
        return _read_wav(path)
    if Path(path).suffix.lower() in (".wav", ".wave"):
        raise DataError(f"{path}: not a WAV file (no RIFF/WAVE header): a corrupt or misnamed file")
    return _read_with_av(path)


def _read_wav(path):
    from scipy.io import wavfile

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fs, data = wavfile.read(path)
    except (ValueError, EOFError, OSError, IndexError, UnboundLocalError) as exc:  # scipy's errors on bad files
        raise DataError(f"{path}: not a readable WAV file ({str(exc).strip() or type(exc).__name__}); "
                        "save the recording as WAV (PCM or float)") from None
    data = np.asarray(data)
    if data.ndim == 1:
        data = data[:, None]
    if data.dtype.kind == "f":
        x, bits = data.astype(np.float64), f"{data.dtype.itemsize * 8}-bit float"
    elif data.dtype == np.uint8:
        x, bits = (data.astype(np.float64) - 128.0) / 128.0, "8-bit"
    elif data.dtype.kind == "i":
        x = data.astype(np.float64) / float(2 ** (8 * data.dtype.itemsize - 1))
        bits = f"{_wav_bits(path) or data.dtype.itemsize * 8}-bit"   # scipy gives 24-bit samples as int32
    else:
        raise DataError(f"{path}: unsupported WAV sample type {data.dtype}")
    return Audio(x, float(fs), f"WAV, {_rate_text(fs)}, {_channels_text(x.shape[1])}, {bits}", False)


def _wav_bits(path):
    """Bits per sample a WAV file's ``fmt `` chunk states (the valid bits of WAVE_FORMAT_EXTENSIBLE), or None."""
    try:
        with open(path, "rb") as fh:
            fh.seek(12)
            for _ in range(64):   # chunks before 'fmt ' (JUNK, bext, LIST): a few at most
                head = fh.read(8)
                if len(head) < 8:
                    return None
                kind, size = head[:4], int.from_bytes(head[4:], "little")
                if kind != b"fmt ":
                    fh.seek(size + (size & 1), 1)
                    continue
                fmt = fh.read(min(size, 40))
                if len(fmt) < 16:
                    return None
                bits = int.from_bytes(fmt[14:16], "little")
                valid = int.from_bytes(fmt[18:20], "little") if len(fmt) >= 20 and fmt[:2] == b"\xfe\xff" else 0
                return valid or bits or None
    except OSError:
        return None
    return None


def _read_with_av(path):
    try:
        import av
    except ImportError:
        raise UsageError(f"{path}: {AUDIO_HINT}") from None
    try:
        with av.open(path) as container:
            if not container.streams.audio:
                raise DataError(f"{path}: no sound track in this file")
            stream = container.streams.audio[0]
            chunks = []
            for frame in container.decode(stream):
                a = frame.to_ndarray()
                if not frame.format.is_planar:
                    a = a.reshape(-1, len(frame.layout.channels)).T
                if a.dtype.kind == "i":
                    a = a.astype(np.float64) / float(2 ** (8 * a.dtype.itemsize - 1))
                elif a.dtype.kind == "u":
                    a = (a.astype(np.float64) - 128.0) / 128.0
                chunks.append(np.asarray(a, dtype=np.float64))
            fs = float(stream.rate or stream.codec_context.sample_rate)
            codec = stream.codec_context.name
    except DataError:
        raise
    except Exception as exc:  # PyAV raises its own error classes (av.error.*)
        raise DataError(f"{path}: not a readable sound or video file ({str(exc).strip() or type(exc).__name__})") \
            from None
    if not chunks:
        raise DataError(f"{path}: the sound track holds no samples")
    x = np.concatenate(chunks, axis=1).T
    return Audio(x, fs, f"{codec} (PyAV), {_rate_text(fs)}, {_channels_text(x.shape[1])}",
                 not codec.startswith(LOSSLESS_CODECS))


def _rate_text(fs):
    return f"{fs / 1000:g} kHz"


def _channels_text(n):
    return {1: "mono", 2: "stereo"}.get(n, f"{n} channels")


# --------------------------------------------------------------------------- onsets


def highpassed(x, fs_hz, corner_hz=HIGHPASS_HZ):
    """Causal 4th-order Butterworth high-pass of every channel (axis 0 = time)."""
    from scipy import signal

    corner = min(corner_hz, 0.2 * fs_hz)
    sos = signal.butter(4, corner, "highpass", fs=fs_hz, output="sos")
    return signal.sosfilt(sos, x, axis=0)


#: A steady tone (a whistle, a machine's whine) is a spectral line this many dB over the spectrum
#: 150-1000 Hz on both sides of it ...
TONE_EXCESS_DB = 20.0
#: ... in the quietest tenth of the frames of every :data:`TONE_STEADY_S` (impacts, their ringing and a room's
#: reverberation come and go; a tone stays) ...
TONE_STEADY_S = 0.5
#: ... carrying this many dB more power than the noise level: it then hides every impact less than about
#: 30 dB over the noise under it (a candidate rises :data:`RISE` times over its background), and is taken
#: out of the onset band (:func:`steady_tones`).
TONE_OVER_NOISE_DB = 20.0
#: A tone wanders this far from its pitch [Hz] (a whistle's vibrato: +- 150 Hz, 6 times a second).
TONE_SPREAD_HZ = 200.0


def steady_tones(y, fs_hz, noise, *, frame_s=0.04, steady_s=TONE_STEADY_S, spread_hz=TONE_SPREAD_HZ,
                 excess_db=TONE_EXCESS_DB, over_noise_db=TONE_OVER_NOISE_DB, low_hz=HIGHPASS_HZ):
    """Frequency bands [Hz] of the steady tones in a high-passed recording: a whistle held for a second
    (2.8 kHz, 44 dB over the noise in a probe's recording) lifted the background of the onset envelope so
    that the impacts under it did not rise 4 times over it, and were lost.

    A tone is a line of the short-time spectrum (frames of ``frame_s``, half overlapping; the power summed
    over ``spread_hz`` either side, the tone's wander) that, in the quietest tenth of the frames of every
    ``steady_s``, stands ``excess_db`` over the median spectrum up to 1 kHz beyond that on both sides and
    carries ``over_noise_db`` more power than ``noise``. Its band runs out from the line to where the
    spectrum is within 3 dB of its sides.

    Parameters
    ----------
    y : ndarray (n, channels)
        high-passed samples, full scale = 1
    fs_hz : float
        sample rate [Hz]
    noise : float
        the noise level (RMS, full scale = 1)
    frame_s, steady_s : float
        frame length and the span a tone holds [s]
    spread_hz : float
        how far a tone wanders from its pitch [Hz]
    excess_db, over_noise_db : float
        as above [dB]
    low_hz : float
        lowest frequency looked at (the high-pass corner) [Hz]

    Returns
    -------
    list of (float, float)
        ``(low, high)`` of each band [Hz], increasing; empty without a steady tone
    """
    from scipy import signal
    from scipy.ndimage import median_filter, percentile_filter, uniform_filter1d

    n = int(2 ** round(math.log2(frame_s * fs_hz)))
    frames = max(3, int(steady_s / (0.5 * n / fs_hz)) | 1)
    if y.shape[0] < n * frames // 2:
        return []
    win = signal.get_window("hann", n)
    f, _, z = signal.stft(y, fs_hz, window=win, nperseg=n, noverlap=n // 2, boundary=None, padded=False, axis=0)
    df = float(f[1])
    half = int(round(spread_hz / df))
    # a tone's power summed over its wander (+- spread_hz), in mean square: the one-sided spectrum of a Hann
    # frame, summed over frequency, is 1.5/2 of the frame's mean square (Parseval)
    scale = 2.0 / (np.sum(win ** 2) * n / np.sum(win) ** 2)
    power = scale * (2 * half + 1) * uniform_filter1d(np.sum(np.abs(z) ** 2, axis=1), 2 * half + 1, axis=0,
                                                      mode="nearest")
    steady = percentile_filter(power, 10, size=(1, frames), mode="nearest")
    near, far = 2 * half + 1, 2 * half + 1 + int(round(1000.0 / df))
    side = np.zeros(2 * far + 1, dtype=bool)
    side[:far - near + 1] = True                                 # offsets -far .. -near
    left = median_filter(steady, footprint=side[:, None], mode="nearest")
    right = median_filter(steady, footprint=side[::-1, None], mode="nearest")
    floor = np.maximum(np.maximum(left, right), 1e-300)
    inside = (f >= low_hz + spread_hz) & (f <= 0.5 * fs_hz - 1000.0)
    line = (steady > 10 ** (excess_db / 10) * floor) & inside[:, None] \
        & (steady - floor > 10 ** (over_noise_db / 10) * noise ** 2)
    if not line.any():
        return []
    loud = line.any(axis=0)
    lifted = np.max(steady[:, loud] / floor[:, loud], axis=1) > 2.0
    bands = []
    for k in np.flatnonzero(line.any(axis=1)):
        if bands and f[k] <= bands[-1][1]:
            continue
        lo, hi = k, k
        while lo > 0 and lifted[lo - 1]:
            lo -= 1
        while hi < f.size - 1 and lifted[hi + 1]:
            hi += 1
        bands.append((float(max(f[lo], 0.5 * low_hz)), float(min(f[hi], 0.49 * fs_hz))))
    return bands


def without_tones(y, fs_hz, bands):
    """``y`` (n, channels) with each band ``(low, high)`` [Hz] stopped (causal 4th-order Butterworth band-stops:
    an onset stays where it is)."""
    from scipy import signal

    for lo, hi in bands:
        sos = signal.butter(4, (lo, hi), "bandstop", fs=fs_hz, output="sos")
        y = signal.sosfilt(sos, y, axis=0)
    return y


def envelope(y, fs_hz, window_s=ENVELOPE_S):
    """RMS over ``window_s`` of a (n, channels) signal, channels summed in energy (centred window)."""
    from scipy.ndimage import uniform_filter1d

    w = max(1, int(round(window_s * fs_hz)))
    energy = np.sum(y * y, axis=1)
    return np.sqrt(np.maximum(uniform_filter1d(energy, w, mode="nearest"), 0.0))


def aic_onset(energy, floor=0.0):
    """Sub-sample index of the variance change point of a window (the AIC picker).

    Parameters
    ----------
    energy : ndarray (N,)
        squared signal (summed over channels) in the window [full scale^2]
    floor : float
        the energy per sample that the samples' rounding alone carries [full scale^2]
        (:attr:`OnsetSignals.floor`): no stretch's mean energy is known below it. Without it a phone's noise
        gate, which leaves exact zeros, made ``ln m`` of a silent stretch -690 and put the change point at
        a stray sample one step off, 1.8 ms before the impact in a probe's recording.

    Returns
    -------
    float
        the onset as a fractional index into the window: ``argmin_k k ln m(0..k) + (N-k) ln m(k..N)``
        (``m`` the mean energy plus ``floor``), refined by a parabola through the minimum and its neighbours.
    """
    k, aic, _, _ = _aic(energy, floor)
    return _refined(k, aic, int(np.argmin(aic)))


def _aic(energy, floor=0.0):
    """The AIC picker's curve over a window (:func:`aic_onset`): the samples ``k`` before each change point
    (2 .. N-2), ``aic(k)``, and the mean energies before and after it (with ``floor``) [full scale^2]."""
    n = energy.size
    c = np.cumsum(energy)
    k = np.arange(2, n - 1)
    before = c[k - 1] / k + floor
    after = (c[-1] - c[k - 1]) / (n - k) + floor
    tiny = 1e-300
    return k, k * np.log(before + tiny) + (n - k) * np.log(after + tiny), before, after


def _refined(k, aic, i):
    """The change point ``k[i]`` of an AIC curve (:func:`_aic`) as a fractional index into the window, refined
    by a parabola through ``aic`` at ``i`` and its neighbours."""
    frac = 0.0
    if 0 < i < aic.size - 1:
        a, b, cc = aic[i - 1], aic[i], aic[i + 1]
        den = a - 2 * b + cc
        if den > 0:
            frac = float(np.clip(0.5 * (a - cc) / den, -0.5, 0.5))
    # k counts samples before the change: the new signal starts at sample k; the change lies
    # between samples k-1 and k (half a sample earlier on a continuous time axis)
    return float(k[i]) - 0.5 + frac


@dataclass(frozen=True)
class OnsetSignals:
    """The signals onsets are found in (from :func:`onset_signals`), kept for the search of
    quiet impacts at predicted times (:func:`extend_chain`).

    Attributes
    ----------
    energy : ndarray (n,)
        squared high-passed signal, summed over channels
    e : ndarray (n,)
        its envelope (RMS over :data:`ENVELOPE_S`)
    rise : ndarray (n,)
        ``e / max(b, noise)``, ``b`` the mean envelope 1-6 ms earlier
    quick_rise : ndarray (n,)
        ``e / max(b', noise)``, ``b'`` the mean envelope 0.25-1.25 ms earlier: a new impact
        rises out of the previous one's decaying ringing, which never rises
    noise : float
        the noise level (median envelope)
    fs_hz : float
        sample rate [Hz]
    pre_echo_s : float
        span before an impact where a lossy codec's pre-echo may lie (0 for lossless audio) [s]
    tones : tuple of (float, float)
        bands [Hz] of the steady tones taken out of the onset band (:func:`steady_tones`)
    floor : float
        energy per sample of the samples' rounding (channels times :func:`quantization_noise` squared)
        [full scale^2]: the least mean energy a stretch of the recording is known to have (:func:`aic_onset`)
    """

    energy: np.ndarray
    e: np.ndarray
    rise: np.ndarray
    quick_rise: np.ndarray
    noise: float
    fs_hz: float
    pre_echo_s: float = 0.0
    tones: tuple = ()
    floor: float = 0.0


def quantization_noise(x):
    """RMS [full scale] of the rounding of samples ``x`` to their own step: q / sqrt(12), q the smallest
    non-zero magnitude of a sample (one step of a 16-bit file, 1/32768: -101 dBFS); 0 for an all-zero signal.

    The noise level of a recording cannot be below it: a phone's noise suppression gates the quiet stretches
    to exact zeros, leaving single samples one step off, and the median envelope of such a file is 0.
    """
    a = np.abs(np.asarray(x, dtype=float))
    a = a[a > 0]
    return float(a.min()) / math.sqrt(12.0) if a.size else 0.0


def onset_signals(x, fs_hz, *, highpass_hz=HIGHPASS_HZ, pre_echo_s=0.0):
    """High-pass, envelope, noise level and rise of a recording (steps 1-2 of the module docstring).

    Parameters
    ----------
    x : ndarray (n,) or (n, channels)
        samples, full scale = 1
    fs_hz : float
        sample rate [Hz]
    highpass_hz : float
        corner of the onset band [Hz]
    pre_echo_s : float
        a lossy codec's pre-echo span (:data:`PRE_ECHO_S`; 0 for lossless audio) [s]: each onset is
        then the start of the impact itself, not of the noise the codec smears before it (:func:`_onset_at`)

    Returns
    -------
    OnsetSignals
    """
    from scipy.ndimage import uniform_filter1d

    x = np.asarray(x, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    y = highpassed(x, fs_hz, highpass_hz)
    # the filter's start-up transient on a DC offset: ignore the first 5 ms
    skip = int(0.005 * fs_hz)
    y[:skip] = 0.0
    e = envelope(y, fs_hz)
    # the median envelope where the recording is not digitally silent, and never below the samples' own
    # rounding: a phone's noise gate leaves exact zeros and stray 1-step samples (a median of 0 made each
    # stray a 44 dB "impact"), and a file padded with zeros put its noise at -181 dBFS
    rounding = quantization_noise(x)

    def noise_level(e):
        live = e[skip:][e[skip:] > rounding]
        level = max(float(np.median(live)) if live.size else 0.0, rounding)
        return level if level > 0 else max(float(np.max(e)) * 1e-6, 1e-12)

    noise = noise_level(e)
    tones = steady_tones(y, fs_hz, noise, low_hz=min(highpass_hz, 0.2 * fs_hz))
    if tones:   # a whistle's line hides the impacts under it: taken out of the onset band
        y = without_tones(y, fs_hz, tones)
        y[:skip] = 0.0
        e = envelope(y, fs_hz)
        noise = noise_level(e)

    def rise(window_s, lag_s):
        w = max(1, int(round(window_s * fs_hz)))
        lag = int(round(lag_s * fs_hz))
        mean = uniform_filter1d(e, w, mode="nearest", origin=(w - 1) // 2)  # mean of e[i-w+1 .. i]
        bg = np.concatenate([np.full(lag, mean[0]), mean[:-lag]]) if lag else mean
        return e / np.maximum(bg, noise)

    return OnsetSignals(energy=np.sum(y * y, axis=1), e=e, rise=rise(5e-3, 1e-3), quick_rise=rise(1e-3, 2.5e-4),
                        noise=noise, fs_hz=float(fs_hz), pre_echo_s=float(pre_echo_s), tones=tuple(tones),
                        floor=x.shape[1] * rounding ** 2)


def _onset_at(sig, p, earliest, latest=None, started=None):
    """Sub-sample onset [s] and peak level over the noise [dB] of the transient whose rise peaks
    at sample ``p`` (the AIC change point from 6 ms before to 0.5 ms after, not before ``earliest``).

    In lossless audio an earlier start the sound rose from the noise at is the onset (:func:`_earlier_start`,
    not before sample ``started``, by default ``earliest``): a noise gate that opened after the impact began.

    In lossy audio (``sig.pre_echo_s`` > 0) the codec spreads the quantisation noise of a transient over
    the transform block before it (pre-echo: 10-35 dB over the noise up to 3 ms before an impact in AAC):
    the rise may peak there, and the change point is the pre-echo's start. So the impact's own start is
    looked for too, as the AIC change point from 0.5 ms after that start to the envelope's peak within
    ``sig.pre_echo_s`` after ``p`` (not at or after sample ``latest``, the next candidate); it is the onset
    when the energy in the millisecond after it is :data:`PRE_ECHO_JUMP_DB` over the energy since the first
    change point. The level is the peak of the envelope in the 2 ms (lossy: ``sig.pre_echo_s``) after ``p``.
    """
    fs = sig.fs_hz
    n = sig.e.size
    start = max(earliest, p - int(round(6e-3 * fs)))
    stop = min(n, p + int(round(5e-4 * fs)))
    if stop - start < 8:
        return None
    onset = start + aic_onset(sig.energy[start:stop], sig.floor)
    end = min(n, p + int(round(max(2e-3, sig.pre_echo_s) * fs)) + 1, latest if latest is not None else n)
    end = max(end, p + 1)
    if sig.pre_echo_s > 0:
        peak = p + int(np.argmax(sig.e[p:end]))
        a, b = int(math.ceil(onset + 5e-4 * fs)), min(n, peak + int(round(5e-4 * fs)))
        if b - a >= 8:
            later = a + aic_onset(sig.energy[a:b], sig.floor)
            k1, k2, w = int(onset), int(later), int(round(1e-3 * fs))
            if k2 > k1 and np.mean(sig.energy[k2:k2 + w]) > np.mean(sig.energy[k1:k2]) * 10 ** (PRE_ECHO_JUMP_DB / 10):
                onset = later
    else:
        onset = _earlier_start(sig, earliest if started is None else started, onset)
    peak_level = float(np.max(sig.e[p:end]))
    return onset / fs, 20.0 * math.log10(peak_level / sig.noise)


def _earlier_start(sig, earliest, onset):
    """The onset [fractional sample] of an impact that began before the change point ``onset`` (lossless
    audio): the change point of the stretch before it (from 6 ms and :data:`GATE_BEFORE_S` before it, not
    before sample ``earliest``) where the sound rises out of the noise by :data:`GATE_STEP_DB`: the
    :data:`GATE_BEFORE_S` or more before it at most that much over the noise level, each half of the sound
    after it (:data:`ENVELOPE_S` or more) that much over them; else ``onset``.

    A phone's noise suppression lets a quiet impact through at a reduced gain until its level over 10 ms
    opens the gate: the jump at the opening was the change point, 2.9 ms after the impact's start, which
    stood 13 dB over the gated noise (a probe's recording). The opening is a gain ramping up (the gate's
    attack): the envelope after it comes within 3 dB of its peak in the next 3 ms only after more than
    :data:`ENVELOPE_S` (0.7-1.3 ms in probes' recordings), where an impact's click does so at once (a voice's
    pitch pulse 2.2 ms before an impact, 12 dB over the noise, is not the impact's start). Not an earlier start
    either: a click that died away before the impact (the half of the stretch next to it is at the level
    before), nor a dip of a room's ringing (it is not at the noise level: in probes' recordings of a gym, a
    superball and 8-16 kHz rates the ringing after a dip 0.3-1.1 ms long was 6-10 dB over it).
    """
    fs = sig.fs_hz
    k1 = int(onset)
    w = max(2, int(round(ENVELOPE_S * fs)))
    known = int(round(GATE_BEFORE_S * fs))
    start = max(earliest, k1 - int(round(6e-3 * fs)) - known)
    if k1 - start < known + w:
        return onset
    after = sig.e[k1:k1 + int(round(3e-3 * fs))]
    if after.size == 0 or int(np.argmax(after >= np.max(after) / math.sqrt(2.0))) <= w:
        return onset     # an abrupt sound of its own at the change point: no gain ramping up
    step = 10 ** (GATE_STEP_DB / 10)
    k, aic, before, after = _aic(sig.energy[start:k1], sig.floor)
    ok = (k >= known) & (k <= k1 - start - w) & (after >= step * before) & (before <= step * sig.noise ** 2)
    if not ok.any():
        return onset
    i = int(np.flatnonzero(ok)[np.argmin(aic[ok])])
    k0, mid = start + int(k[i]), start + (int(k[i]) + k1 - start) // 2
    rose = min(np.mean(sig.energy[k0:mid]), np.mean(sig.energy[mid:k1])) + sig.floor
    return start + _refined(k, aic, i) if rose >= step * before[i] else onset


def impact_onsets(x, fs_hz, *, highpass_hz=HIGHPASS_HZ, rise=RISE, snr=SNR, signals=None):
    """Candidate impact onsets of a recording (every transient that rises out of the noise).

    Parameters
    ----------
    x, fs_hz, highpass_hz
        the samples (full scale = 1), sample rate [Hz] and onset band's corner [Hz], as in
        :func:`onset_signals`
    rise, snr : float
        a candidate's envelope exceeds ``rise`` times the level 1-6 ms before it and ``snr``
        times the noise level
    signals : OnsetSignals, optional
        :func:`onset_signals` of ``x`` when already computed

    Returns
    -------
    Onsets
        onset times (AIC change point, sub-sample) and peak level over the noise [dB].
    """
    from scipy.signal import find_peaks

    sig = signals if signals is not None else onset_signals(x, fs_hz, highpass_hz=highpass_hz)
    ratio = np.where(sig.e < snr * sig.noise, 0.0, sig.rise)
    peaks, _ = find_peaks(ratio, height=rise, distance=max(1, int(REFRACTORY_S * fs_hz)))
    times, levels = [], []
    last = since = 0
    for k, p in enumerate(peaks):
        # the start of the rise: back from the peak of the rise to where e leaves the background
        following = int(peaks[k + 1]) if k + 1 < peaks.size else None
        found = _onset_at(sig, int(p), last, following)
        if found is None:
            continue
        if times and sig.pre_echo_s == 0 and found[1] > levels[-1] + GATE_STEP_DB:
            # louder than a bounce after the one before may be: a noise gate's opening on the candidate before,
            # when that one's start is where this sound rose from the noise (one impact, not two)
            same = _onset_at(sig, int(p), last, following, started=since)
            if same is not None and same[0] <= times[-1] + ENVELOPE_S:
                levels[-1] = found[1]
                last = int(p)
                continue
        times.append(found[0])
        levels.append(found[1])
        since, last = last, int(p)
    return Onsets(t_s=np.asarray(times), snr_db=np.asarray(levels), noise_level=sig.noise)


# --------------------------------------------------------------------------- physics: the bouncing sequence


def bounce_sequence(t_s, level_db, *, tolerance=RATIO_TOLERANCE, min_interval_s=0.005, max_louder_db=6.0,
                    max_ratio=0.98, max_interval_s=3.0):
    """Indices of the candidates that form a bouncing ball's impacts, and why the others do not.

    A ball's flight times shrink geometrically, ``dt_{i+1} ~ r dt_i`` (r ~ epsilon, 0.3 < r < 1).
    Every pair of a start and a first interval, with every third candidate giving a first
    ratio in (0.3, ``max_ratio``), seeds a chain that is extended while a candidate lies within
    ``tolerance`` of the predicted next interval ``r dt`` (r the median of the last three
    ratios; the loudest candidate in that window is taken). An impact may not be louder
    than the one before it by more than ``max_louder_db`` (each bounce is slower). The
    longest chain wins (not one that steps over every other impact, :func:`_skips_every_other`); among
    equally long ones the louder, then the more regular. Its first
    event is then left out while it is no impact of the sequence
    (:func:`vrcal.measurements.cleanup.leading_intruder`: a clap just before the release). A chain
    whose longest flight rises a few mm is no recorded drop (a voice's pulses,
    :func:`vrcal.measurements.cleanup.no_recorded_drop`): none is returned, and its events' reason
    says why.

    Parameters
    ----------
    t_s : ndarray
        candidate times [s], increasing
    level_db : ndarray
        candidate levels over the noise [dB]
    tolerance : float
        relative deviation of an interval from its prediction still accepted
    min_interval_s : float
        shortest first interval of a chain [s]
    max_louder_db : float
        largest rise of loudness from one impact to the next [dB]
    max_interval_s : float
        longest first interval [s] (a 3 s flight is a bounce 11 m high)
    max_ratio : float
        every interval is shorter than ``max_ratio`` times the one before (the flights
        shrink: a periodic train of pulses, as a voice's, is no bounce sequence)

    Returns
    -------
    chain : ndarray of int
        indices of the impacts, increasing (empty when fewer than three candidates fit, or when
        the best chain is no recorded drop)
    reasons : dict
        ``{index: reason}`` for every candidate not in the chain
    """
    t = np.asarray(t_s, dtype=float)
    lv = np.asarray(level_db, dtype=float)
    n = t.size
    # plain floats and bisect: the seeds are many (51,000 for a voice's 200 pulses) and each step looks at a
    # few events, where numpy's per-call overhead took 13 s; the arithmetic is the same float64
    tl, ll = t.tolist(), lv.tolist()
    best, best_key = [], None
    for i in range(n):
        for j in range(i + 1, n):
            dt0 = tl[j] - tl[i]
            if dt0 > max_interval_s:
                break
            if dt0 < min_interval_s or ll[j] > ll[i] + max_louder_db:
                continue
            # third impacts: t[j] + 0.3 dt0 < t < t[j] + max_ratio dt0
            for k in range(bisect.bisect_right(tl, tl[j] + 0.3 * dt0), bisect.bisect_left(tl, tl[j] + max_ratio * dt0)):
                if ll[k] > ll[j] + max_louder_db:
                    continue
                chain = [i, j, k]
                ratios = [(tl[k] - tl[j]) / dt0]
                while True:
                    r = _median_of_few(ratios[-3:])
                    last = chain[-1]
                    dt = tl[last] - tl[chain[-2]]
                    target = tl[last] + r * dt
                    width = tolerance * r * dt
                    fits = [q for q in range(max(bisect.bisect_left(tl, target - width) - 1, last + 1),
                                             min(bisect.bisect_right(tl, target + width) + 1, n))
                            if abs(tl[q] - target) <= width and ll[q] <= ll[last] + max_louder_db
                            and tl[q] - tl[last] < max_ratio * dt]
                    if not fits:
                        break
                    m = _best_fit(fits, tl, ll, target, width, max_louder_db)
                    ratios.append((tl[m] - tl[last]) / dt)
                    chain.append(m)
                if best_key is not None and len(chain) < best_key[0]:
                    continue
                if _skips_every_other(tl, ll, chain, ratios, max_louder_db=max_louder_db):
                    continue
                spread = float(np.std(np.log(ratios))) if len(ratios) > 1 else 0.0
                key = (len(chain), float(np.sum(lv[chain])), -spread)
                if best_key is None or key > best_key:
                    best, best_key = chain, key
    chain = np.asarray(best, dtype=int)
    intruders = {}
    while chain.size > MIN_IMPACTS:   # a clap or a word just before the release can fit the tolerance
        why = leading_intruder(t[chain])
        if why is None:
            break
        intruders[int(chain[0])] = why
        chain = chain[1:]
    if chain.size < MIN_IMPACTS:
        return np.zeros(0, dtype=int), {i: "no bouncing sequence" for i in range(n)}
    why = no_recorded_drop(t[chain])
    if why is not None:    # a voice's pulses: a "sequence" whose longest flight rises a few mm
        return np.zeros(0, dtype=int), {i: why if i in set(chain.tolist()) else "no bouncing sequence"
                                        for i in range(n)}
    return chain, {**rejection_reasons(t, chain, tolerance), **intruders}


def _skips_every_other(t, level, chain, ratios, *, spread=0.03, max_louder_db=6.0, min_skipped=2):
    """Whether a chain steps over every other impact: impacts lost under a louder sound (a drum's hit) break
    the true chain, and the one through every other impact shrinks steadily too, by epsilon^2 (a tennis
    ball's 0.76 gave 0.5776, "explained"). Such a chain's flights hold an event where the impact it stepped
    over falls, a fraction 1 / (1 + sqrt(r)) into the flight (r the chain's median ratio; within ``spread``
    of the flight, a ball's ratios scattering by a few per cent), as loud as an impact between its
    neighbours can be (within ``max_louder_db``). Flights whose stepped-over impact would come within
    :data:`ECHO_WITHIN_MS` of the impact before are not judged (an echo falls there). With at least
    ``min_skipped`` and a third of the judged flights so, the chain is no bounce sequence.

    Parameters
    ----------
    t, level : list of float
        every event's time [s] (increasing) and level [dB]
    chain : list of int
        the chain's indices into ``t``
    ratios : list of float
        its interval ratios
    spread : float
        tolerance of the stepped-over impact's time, as a fraction of the flight
    max_louder_db : float
        as in :func:`bounce_sequence`
    min_skipped : int
        fewest flights stepping over an impact
    """
    root = math.sqrt(float(np.median(ratios)))
    members = set(chain)
    judged = skipped = 0
    for a, b in zip(chain[:-1], chain[1:]):
        flight = t[b] - t[a]
        at = t[a] + flight / (1.0 + root)
        if at - t[a] <= ECHO_WITHIN_MS * 1e-3:
            continue
        judged += 1
        lo, hi = bisect.bisect_left(t, at - spread * flight), bisect.bisect_right(t, at + spread * flight)
        skipped += any(q not in members and level[b] - max_louder_db <= level[q] <= level[a] + max_louder_db
                       for q in range(lo, hi))
    return skipped >= min_skipped and 3 * skipped >= judged


def _best_fit(fits, t, level, target, width, max_louder_db):
    """The event of ``fits`` (indices into ``t`` and ``level``, times [s] and levels [dB]) that continues a
    bounce chain whose next impact is predicted at ``target`` [s], ``width`` [s] the window's half-width: the
    loudest (an impact outshines voices and echoes), unless it lies in the outer half of the window and an
    event within ``max_louder_db`` of it lies in the inner half, which is then the bounce (the loudest of
    those). A ball's flights follow the prediction to a few per cent, the window allows 12: a key click
    13 ms before a bounce, at the window's edge and 3 dB louder, was taken for it in a probe's recording of
    typing, and the chain stopped there."""
    m = max(fits, key=lambda q: level[q])
    if abs(t[m] - target) <= 0.5 * width:
        return m
    inner = [q for q in fits if abs(t[q] - target) <= 0.5 * width and level[q] >= level[m] - max_louder_db]
    return max(inner, key=lambda q: level[q]) if inner else m


def _median_of_few(values):
    """The median of a short list of floats, as np.median gives it (the mean of the middle two of an even
    count), without numpy's overhead on three numbers."""
    s = sorted(values)
    n = len(s)
    return s[n // 2] if n % 2 else 0.5 * (s[n // 2 - 1] + s[n // 2])


#: An event this soon after an impact [ms] is called its echo or ringing (a wall up to 10 m away).
ECHO_WITHIN_MS = 60.0


def rejection_reasons(t_s, chain, tolerance=RATIO_TOLERANCE):
    """``{index: reason}`` for every candidate time in ``t_s`` not in the bounce ``chain``."""
    t = np.asarray(t_s, dtype=float)
    reasons = {}
    kept = set(int(i) for i in chain)
    for i in range(t.size):
        if i in kept:
            continue
        before = chain[t[chain] < t[i]]
        if before.size == 0:
            reasons[i] = "before the first impact"
        elif before.size == chain.size:
            reasons[i] = _after_chain_reason(t[chain], t[i], tolerance)
        else:
            prev = int(before[-1])
            gap = (t[i] - t[prev]) * 1e3
            # sound goes 20 m there and back in 60 ms: a room's walls echo within that
            kind = "echo or ringing" if gap < ECHO_WITHIN_MS else "a noise (clap, voice, ...)"
            reasons[i] = f"{kind}: {gap:.1f} ms after an impact, off the bounce sequence"
    return reasons


def _after_chain_reason(t_chain, t_i, tolerance):
    """Why an event after the chain's last impact is not in it: a later impact after ones not
    heard (the fit needs consecutive impacts), or a noise."""
    dt = np.diff(t_chain)
    r = float(np.median(dt[1:] / dt[:-1]))
    later = t_chain[-1] + np.cumsum(dt[-1] * r ** np.arange(1, 9))  # the next eight predicted impacts
    k = int(np.argmin(np.abs(later - t_i)))
    step = dt[-1] * r ** (k + 1)
    gap_ms = (t_i - t_chain[-1]) * 1e3
    if k >= 1 and abs(later[k] - t_i) <= 2 * tolerance * step:
        return (f"a later impact ({gap_ms:.1f} ms after the last one kept) after {k} not heard: "
                "left out (the fit needs consecutive impacts)")
    return f"after the last impact, off the bounce sequence ({gap_ms:.1f} ms later)"


def window_threshold(n_samples, fs_hz, false_alarm=WINDOW_FALSE_ALARM, highpass_hz=HIGHPASS_HZ):
    """Level over the noise that Gaussian noise alone exceeds in a window of ``n_samples`` with
    probability ``false_alarm``.

    The envelope is an RMS over :data:`ENVELOPE_S` of noise in the band from the high-pass
    corner to :data:`AUDIO_BAND_HZ` (or half the sample rate): its square over the noise
    variance is chi-squared with ``m = 2 B T`` degrees of freedom over ``m`` (``B`` the band
    width, ``T`` = :data:`ENVELOPE_S`); the window holds ``n_samples / (T fs)`` independent
    looks, and the noise level is the envelope's median.

    Parameters
    ----------
    n_samples : int
        length of the window [samples]
    fs_hz : float
        sample rate [Hz]
    false_alarm : float
        chance of a false alarm in the window
    highpass_hz : float
        high-pass corner of the onset band [Hz]

    Returns
    -------
    float
        threshold on ``e / noise`` (and so on the rise, which is at most ``e / noise``)
    """
    from scipy.stats import chi2

    band_hz = min(0.5 * fs_hz, AUDIO_BAND_HZ) - min(highpass_hz, 0.2 * fs_hz)
    m = max(1.0, 2.0 * band_hz * ENVELOPE_S)
    looks = max(1.0, n_samples / max(1.0, ENVELOPE_S * fs_hz))
    return float(math.sqrt(chi2.isf(false_alarm / looks, m) / chi2.median(m)))


def extend_chain(signals, t_s, level_db, *, tolerance=RATIO_TOLERANCE, max_louder_db=6.0, max_ratio=0.98,
                 others_s=()):
    """The quiet impacts after a bounce chain, searched for only where the physics predicts them.

    The next impact lies near ``t_last + r dt_last`` (``r`` the median of the last three
    interval ratios, as in :func:`bounce_sequence`). Only the window of ``tolerance r dt``
    around that time is searched, so the threshold can be the level noise alone exceeds there
    once in 1/:data:`WINDOW_FALSE_ALARM` windows (:func:`window_threshold`, about 2.7 times the
    noise, against :data:`SNR` over the whole file, where claps and voices must not pass).
    The statistic is the quick rise (the envelope over its level 0.25-1.25 ms before: the
    ringing of the impact before decays and never rises); its largest peak in the window is
    timed by the same AIC change point as every onset. Where a noise gate closed before the window (the
    stretch before it far under the noise level), a sound is judged on its envelope over the gated floor, or
    over the noise level if it reaches it (:func:`_over_the_gated_floor`). The chain stops at the first window with
    nothing over the threshold, a peak louder than the impact before by ``max_louder_db``, or an event known
    to be no impact (a voice's pitch pulse, a beat) in it or in the 6 ms the onset is sought before it (a
    pulse there is what the window finds: 3-5 ms early in a probe's recording): the bounces after it are left
    out, not guessed.

    Parameters
    ----------
    signals : OnsetSignals
        from :func:`onset_signals`
    t_s, level_db : ndarray
        times [s] and levels [dB] of the chain's impacts, increasing (at least three)
    tolerance, max_louder_db, max_ratio : float
        as in :func:`bounce_sequence`
    others_s : array_like
        times of events known to be no impact [s]: a voice's pitch pulses, a beat's
        (:func:`vrcal.measurements.cleanup.voice_pulses`, :func:`vrcal.measurements.cleanup.steady_beat`)

    Returns
    -------
    t_new, level_new : ndarray
        onsets [s] and levels over the noise [dB] of the impacts found after the chain
    threshold : float
        the largest window threshold used (over the noise)
    """
    fs = signals.fs_hz
    n = signals.e.size
    t = list(np.asarray(t_s, dtype=float))
    lv = list(np.asarray(level_db, dtype=float))
    ratios = list(np.diff(t)[1:] / np.diff(t)[:-1])
    others = np.asarray(others_s, dtype=float)
    added, worst = 0, 0.0
    while True:
        r = float(np.median(ratios[-3:]))
        dt = t[-1] - t[-2]
        if not 0.0 < r < max_ratio or r * dt < REFRACTORY_S:  # impacts closer than that are one sound
            break
        target, width = t[-1] + r * dt, max(tolerance * r * dt, 5e-4)
        if np.any((others >= target - width - 6e-3) & (others <= target + width)):
            break
        lo, hi = int(math.ceil((target - width) * fs)), int(math.floor((target + width) * fs)) + 1
        if hi > n or lo <= int(t[-1] * fs):
            break
        thr = window_threshold(hi - lo, fs)
        worst = max(worst, thr)
        p = lo + int(np.argmax(signals.quick_rise[lo:hi]))
        if signals.quick_rise[p] < thr:
            p = _over_the_gated_floor(signals, lo, hi, thr, int(math.ceil((t[-1] + REFRACTORY_S) * fs)))
            if p is None:
                break
        found = _onset_at(signals, p, int(math.ceil((t[-1] + 1e-3) * fs)))
        if found is None or found[1] > lv[-1] + max_louder_db or not t[-1] < found[0]:
            break
        ratios.append((found[0] - t[-1]) / dt)
        t.append(found[0])
        lv.append(found[1])
        added += 1
    return np.asarray(t[len(t) - added:]), np.asarray(lv[len(lv) - added:]), worst


def _over_the_gated_floor(signals, lo, hi, thr, since, before_s=0.02):
    """The sample [index] where a sound in the window ``lo:hi`` [samples] first stands ``thr`` times over the level a
    noise gate leaves there, or None: the window's statistic where the stretch before it (``before_s`` [s],
    not before sample ``since``) is gated, its median envelope under the noise level by ``thr`` or more.

    The noise level (the median envelope where the recording is not digitally silent) is the noise while the
    gate is open: a gate that leaves exact zeros between the sounds keeps only the open stretches. Behind a
    closed gate the noise is the gated floor, the stretch's median envelope, never below the samples' own
    rounding (:func:`quantization_noise`); a sound under the noise level there is heard only because the gate
    is closed, and is judged against that floor. A sound that reaches the noise level may be the gate opening
    on the noise alone: it is judged against the noise level. Either way the sound rose out of the floor, so
    the level is its envelope's peak in the window over that noise, not the quick rise, which the gate's
    attack (a gain ramping up over milliseconds) keeps under the threshold: an impact 14 dB over the open
    gate's noise, 65 dB over the gated floor, rose by 2.6 times within a millisecond in a probe's recording.
    Whether a sound reached the noise level is judged on its envelope up to :data:`REFRACTORY_S` after the
    window (a gate's opening ramps up after the window's end).
    """
    start = max(since, lo - int(round(before_s * signals.fs_hz)))
    if lo - start < max(2, int(round(ENVELOPE_S * signals.fs_hz))):
        return None
    floor = max(float(np.median(signals.e[start:lo])), math.sqrt(signals.floor))
    if floor * thr > signals.noise:
        return None
    sound = float(np.max(signals.e[lo:min(signals.e.size, hi + int(round(REFRACTORY_S * signals.fs_hz)))]))
    over = signals.e[lo:hi] >= thr * (signals.noise if sound >= signals.noise else floor)
    return lo + int(np.argmax(over)) if over.any() else None


# --------------------------------------------------------------------------- the reader


@dataclass(frozen=True)
class SoundTrack:
    """What :func:`track_sound` found: the impacts kept, every candidate, and the signal."""

    impacts: ImpactTimes
    onsets: Onsets
    chain: np.ndarray
    reasons: dict
    fs_hz: float
    x: np.ndarray
    what: str
    second: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))  # a second drop's onsets

    @property
    def snr_db(self):
        """Level of each kept impact over the noise [dB]."""
        return self.onsets.snr_db[np.searchsorted(self.onsets.t_s, self.impacts.t_s)]


def track_sound(path, *, progress=None):
    """Read a sound recording and find the impact times (see the module docstring).

    Parameters
    ----------
    path : str or Path
        WAV (any other container with the optional PyAV)
    progress : callable, optional
        ``progress(fraction, message)`` for long recordings

    Returns
    -------
    SoundTrack
    """
    path = str(path)
    if progress:
        progress(0.0, "reading the sound")
    x, fs, what, lossy = read_audio(path)
    if fs < MIN_SAMPLE_RATE_HZ:
        raise DataError(f"{path}: sampled at {fs:g} Hz, below the {MIN_SAMPLE_RATE_HZ:.0f} Hz vrcal reads (an impact's "
                        f"click lies above {HIGHPASS_HZ:.0f} Hz); record at 44.1 or 48 kHz")
    n = x.shape[0]
    if n < int(0.05 * fs):
        raise DataError(f"{path}: the recording is only {n / fs * 1e3:.0f} ms long; record the whole drop")
    peak = float(np.max(np.abs(x))) if x.size else 0.0
    if peak == 0.0 or not np.isfinite(peak):
        raise DataError(f"{path}: the recording is silent (every sample is 0); check the microphone")
    notes = [f"recording: {what}, {n / fs:.2f} s"]
    if lossy:
        notes.append(f"lossy coding: each onset is the impact's own start, not of the pre-echo the codec smears up "
                     f"to {PRE_ECHO_S * 1e3:g} ms before it (a WAV or FLAC recording is timed better)")
    clipped = int(np.sum(np.abs(x) >= 0.999 * max(peak, 0.0))) if peak >= 0.99 else 0
    if clipped > 3:
        notes.append(f"clipped: {clipped} samples at full scale (onsets are timed at the start of each "
                     "impact, which clipping does not move)")
    if progress:
        progress(0.3, "finding onsets")
    signals = onset_signals(x, fs, pre_echo_s=PRE_ECHO_S if lossy else 0.0)
    if signals.tones:
        notes.append("steady tone (a whistle, a machine's whine) in the onset band, stopped before the onsets were "
                     "sought (it hides the impacts under it): "
                     + ", ".join(f"{lo / 1000:.2f}-{hi / 1000:.2f} kHz" for lo, hi in signals.tones))
    onsets = impact_onsets(x, fs, signals=signals)
    if progress:
        progress(0.8, "checking the bounce sequence")
    if onsets.t_s.size == 0:
        raise DataError(f"{path}: no impact sounds found (loudest transient below {SNR:g} x the noise level, "
                        f"peak {20 * math.log10(peak):.0f} dBFS); record closer to the floor or in a quieter room. "
                        f"{DULL_IMPACTS}")
    onsets, others, others_s = _without_voice_and_beat(onsets)
    if others and onsets.t_s.size == 0:
        raise DataError(f"{path}: every sound event is a voice's, a hum's or a beat's ({'; '.join(others)}): "
                        f"{NOT_A_DROP}; is this a drop recording? record the whole drop, the phone near the floor")
    notes.extend(f"{what}: left out before the bounce sequence was sought" for what in others)
    chain, reasons = _bounce_sequence_among_loudest(onsets, notes)
    no_drop = [i for i, why in reasons.items() if why.startswith(NOT_A_DROP)]
    if no_drop:
        t0, t1 = onsets.t_s[no_drop[0]], onsets.t_s[no_drop[-1]]
        raise DataError(f"{path}: {onsets.t_s.size} sound events; the best bounce sequence ({len(no_drop)}, t = "
                        f"{t0:.3f}-{t1:.3f} s) is {reasons[no_drop[0]]}; is this a drop recording? record the whole "
                        "drop, the phone near the floor")
    if chain.size < MIN_IMPACTS:
        raise DataError(f"{path}: {onsets.t_s.size} sound event(s) but no {MIN_IMPACTS} of them form a bouncing "
                        f"sequence (intervals shrinking by a steady ratio); is this a drop recording? {DULL_IMPACTS}")
    n_heard = chain.size
    suspect = ()
    if onsets.t_s.size >= CHANCE_MIN_EVENTS:
        lengths = chance_chain_lengths(onsets)
        if n_heard < CHANCE_MARGIN * float(np.median(lengths)):
            suspect = (f"the bounce sequence heard ({n_heard} impacts among {onsets.t_s.size} sound events) is not "
                       f"{CHANCE_MARGIN:g} times as long as chance makes among as many events: with their times "
                       f"shuffled, {CHANCE_SHUFFLES} tries gave {', '.join(str(k) for k in lengths)}; the impacts "
                       "may be noise (record in a quiet room, the phone near the floor)",)
    t_new, lv_new, threshold = extend_chain(signals, onsets.t_s[chain], onsets.snr_db[chain], others_s=others_s)
    if t_new.size:
        intruders = {float(onsets.t_s[i]): why for i, why in reasons.items() if why.startswith(NOT_AN_IMPACT)}
        onsets, chain = _with_impacts(onsets, chain, t_new, lv_new)
        reasons = rejection_reasons(onsets.t_s, chain)
        reasons.update({int(np.searchsorted(onsets.t_s, t0)): why for t0, why in intruders.items()})
    second = _second_drop(onsets, chain)
    for i in second:
        reasons.pop(int(i), None)
    impacts_note = len(notes)    # written once the impacts fitted are known (a second drop's included)
    if t_new.size:
        notes.append(f"quiet end: {t_new.size} impact(s) after impact {n_heard} found in the windows where the "
                     f"bounce sequence predicts them (rising over {threshold:.1f} x the noise there, where noise "
                     f"alone does so once in {1 / WINDOW_FALSE_ALARM:.0e} windows)")
    shown = sorted(reasons, key=lambda i: (not reasons[i].startswith(NOT_AN_IMPACT), i))   # a clap taken out first
    for i in shown[:MAX_LISTED]:
        notes.append(f"event at t = {onsets.t_s[i]:.4f} s ({onsets.snr_db[i]:.0f} dB) rejected: {reasons[i]}")
    if len(shown) > MAX_LISTED:
        rest = onsets.t_s[shown[MAX_LISTED:]]
        notes.append(f"... and {len(shown) - MAX_LISTED} more events off the bounce sequence rejected "
                     f"(t = {np.min(rest):.3f} - {np.max(rest):.3f} s)")
    t = onsets.t_s[chain]
    dt = np.diff(t)
    r = float(np.median(dt[1:] / dt[:-1])) if dt.size > 1 else float("nan")
    expected = t[-1] + r * dt[-1]
    if expected < n / fs:
        notes.append(f"the sound ends in the noise after impact {chain.size} at t = {t[-1]:.4f} s "
                     f"({onsets.snr_db[chain[-1]]:.0f} dB over the noise): the next bounce, expected near "
                     f"t = {expected:.3f} s, and later ones are not heard and left out")
    else:
        notes.append(f"the recording ends {n / fs - t[-1]:.3f} s after the last impact heard "
                     f"(the next was expected at t = {expected:.3f} s)")
    n_clean, rejected = detect_impact_anomalies(t)
    if rejected:
        idx, t0, reason = rejected[0]
        notes.append(f"impact {idx + 1} at t = {t0:.4f} s: {reason}; fitting the {n_clean} impacts before it, "
                     f"{len(rejected)} rejected")
    if n_clean < MIN_IMPACTS:
        raise DataError(f"{path}: only {n_clean} impact(s) before an anomaly ({rejected[0][2]}); "
                        f"at least {MIN_IMPACTS} are needed")
    t_all, chains = t[:n_clean], ()
    if second.size:
        t2 = onsets.t_s[second]
        n2, _ = detect_impact_anomalies(t2)
        if n2 >= MIN_IMPACTS:
            notes.append(f"a second drop: {n2} impacts from t = {t2[0]:.4f} s form a bounce sequence of their own; "
                         f"fitted jointly with the first (one epsilon, each drop its own height)")
            t_all, chains = np.concatenate([t_all, t2[:n2]]), ((0, n_clean), (n_clean, n_clean + n2))
    how = (f"(onsets by the AIC change point after a {HIGHPASS_HZ / 1000:g} kHz high-pass; noise level "
           f"{20 * math.log10(onsets.noise_level):.0f} dBFS)")
    if chains:
        notes.insert(impacts_note, f"impacts: {t_all.size} of {onsets.t_s.size} sound events form two bounce "
                                   f"sequences ({n_clean} in the first drop, {t_all.size - n_clean} in a second) {how}")
    else:
        notes.insert(impacts_note, f"impacts: {chain.size} of {onsets.t_s.size} sound events form the bounce "
                                   f"sequence {how}")
    impacts = ImpactTimes(t_s=t_all, source=path, notes=tuple(notes), rejected=rejected, chains=chains,
                          instrument_sd_s=0.0 if lossy else LOSSLESS_TIMING_SD_S, suspect=suspect)
    if progress:
        progress(1.0, "done")
    return SoundTrack(impacts=impacts, onsets=onsets, chain=chain, reasons=reasons, fs_hz=fs, x=x, what=what,
                      second=second)


def _without_voice_and_beat(onsets):
    """``onsets`` without the pitch pulses of a voice or a hum (:func:`vrcal.measurements.cleanup.voice_pulses`)
    and the events of a steady beat (music, a clock: :func:`vrcal.measurements.cleanup.steady_beat`), what was
    left out (a list of "k of n sound events are ...") and the times left out [s]. Talking through a drop
    gave hundreds of events; the longest chain through them mixed pulses with impacts (8 of 22 "impacts" a
    voice's, with the speech 26 dB below the first impact); a drum's eighth notes with every other impact
    made a chain of ratio 0.5."""
    t, level = onsets.t_s, onsets.snr_db
    said = []
    voice = voice_pulses(t, level)
    if voice.any():
        dt = np.diff(t)
        within = dt[voice[:-1] & voice[1:] & (dt >= PULSE_PERIODS_S[0]) & (dt <= PULSE_PERIODS_S[1])]
        said.append(f"{int(voice.sum())} of {t.size} sound events are pitch pulses of a voice or a hum "
                    f"({within.min() * 1e3:.1f}-{within.max() * 1e3:.1f} ms apart, t = {t[voice].min():.2f}-"
                    f"{t[voice].max():.2f} s)")
    beat = np.zeros(t.size, dtype=bool)
    beat[~voice] = steady_beat(t[~voice])
    if beat.any():
        tb = t[beat]
        period = float(np.min(np.diff(tb)))
        said.append(f"{int(beat.sum())} of {t.size} sound events keep a steady beat (music, a clock: on a grid "
                    f"{period * 1e3:.0f} ms apart, t = {tb.min():.2f}-{tb.max():.2f} s)")
    out = voice | beat
    kept = Onsets(t_s=t[~out], snr_db=level[~out], noise_level=onsets.noise_level) if out.any() else onsets
    return kept, said, t[out]


#: The bounce sequence is sought among at most this many sound events, the loudest (:func:`bounce_sequence`
#: tries every start, first interval and third impact: 1,800 events, a minute of applause, took 41 s).
MAX_CHAIN_EVENTS = 600


def _bounce_sequence_among_loudest(onsets, notes):
    """:func:`bounce_sequence` of ``onsets`` (indices into it, and ``{index: reason}`` for every other event),
    among the :data:`MAX_CHAIN_EVENTS` loudest when there are more, with a note appended to ``notes``: a
    drop's first impacts are its loudest sounds, and its quiet end is searched for where the sequence
    predicts it (:func:`extend_chain`)."""
    n = onsets.t_s.size
    if n <= MAX_CHAIN_EVENTS:
        return bounce_sequence(onsets.t_s, onsets.snr_db)
    sought = np.sort(np.argsort(-onsets.snr_db, kind="stable")[:MAX_CHAIN_EVENTS])
    notes.append(f"{n} sound events: the bounce sequence was sought among the {MAX_CHAIN_EVENTS} loudest "
                 f"(over {float(onsets.snr_db[sought].min()):.0f} dB); a noisy room (applause, rain, a crowd)?")
    found, why = bounce_sequence(onsets.t_s[sought], onsets.snr_db[sought])
    chain = sought[found]
    reasons = rejection_reasons(onsets.t_s, chain) if chain.size else {i: "no bouncing sequence" for i in range(n)}
    reasons.update({int(sought[i]): reason for i, reason in why.items()})
    return chain, reasons


#: With this many sound events or more the bounce sequence is checked against chance
#: (:func:`chance_chain_lengths`; fewer events make chance chains of a few, and a length test alone then
#: doubts real drops: typing at 8 keys a second, 48 events, made chains of 7-10 beside a drop heard for 9
#: impacts, which the search had still found right) ...
CHANCE_MIN_EVENTS = 100
#: ... in this many shuffles of the events' times; a sequence heard shorter than this many times the median
#: length they give is suspect (a drop's is far longer: 12 impacts and more where chance makes 3-5; a
#: minute of applause gave 24 where its shuffles gave 18-26).
CHANCE_SHUFFLES = 3
CHANCE_MARGIN = 1.5


def chance_chain_lengths(onsets, *, shuffles=CHANCE_SHUFFLES, seed=0):
    """Lengths of the bounce sequences found among ``onsets`` with their times shuffled: each time drawn at
    random over the events' span, the levels kept (:func:`bounce_sequence`, among the loudest as
    :func:`_bounce_sequence_among_loudest` seeks). A sequence found in the recording not much longer than
    these (:data:`CHANCE_MARGIN`) is what chance makes among so many events: in a minute of applause (15
    clicks a second) chains of 16-24 clicks formed, longer than the drop's 12 impacts.

    Parameters
    ----------
    onsets : Onsets
        the sound events the sequence was sought among
    shuffles : int
        how many shuffles
    seed : int
        of the random times (the result is the same at every run)

    Returns
    -------
    list of int
    """
    rng = np.random.default_rng(seed)
    t0, t1 = float(onsets.t_s[0]), float(onsets.t_s[-1])
    lengths = []
    for _ in range(shuffles):
        t = np.sort(rng.uniform(t0, t1, onsets.t_s.size))
        level = rng.permutation(onsets.snr_db)
        chain, _ = _bounce_sequence_among_loudest(Onsets(t_s=t, snr_db=level, noise_level=onsets.noise_level), [])
        lengths.append(int(chain.size))
    return lengths


#: A second drop of the same ball (:func:`_second_drop`): at least this many impacts ...
SECOND_DROP_MIN_IMPACTS = 4
#: ... whose median interval ratio is within this (relative) of the first drop's: one ball, one epsilon
#: (drag changes the ratio by a few per cent between heights: a tennis ball from 0.65 or 1.6 m).
SECOND_DROP_RATIO_TOLERANCE = 0.10


def _second_drop(onsets, chain):
    """Indices into ``onsets`` of a second bounce sequence heard after the first one's last impact (a
    recording of two drops), or an empty array.

    It is the same ball's only with :data:`SECOND_DROP_MIN_IMPACTS` impacts or more, shrinking by the first
    drop's ratio within :data:`SECOND_DROP_RATIO_TOLERANCE`: three footsteps or key clicks, or a drum's hits
    4, 2 and 1 eighth notes apart (ratio 0.5 against a tennis ball's 0.76), were fitted as a second drop."""
    after = np.flatnonzero(onsets.t_s > onsets.t_s[chain[-1]] + 0.05)
    if after.size < SECOND_DROP_MIN_IMPACTS:
        return np.zeros(0, dtype=int)
    found, _ = bounce_sequence(onsets.t_s[after], onsets.snr_db[after])
    if found.size < SECOND_DROP_MIN_IMPACTS:
        return np.zeros(0, dtype=int)
    dt1, dt2 = np.diff(onsets.t_s[chain]), np.diff(onsets.t_s[after[found]])
    r1, r2 = float(np.median(dt1[1:] / dt1[:-1])), float(np.median(dt2[1:] / dt2[:-1]))
    return after[found] if abs(r2 / r1 - 1.0) <= SECOND_DROP_RATIO_TOLERANCE else np.zeros(0, dtype=int)


def _with_impacts(onsets, chain, t_new, level_new, same_s=1e-3):
    """``onsets`` with the impacts found by :func:`extend_chain` added (a candidate already
    within ``same_s`` of one is that impact), and the chain's indices into the new onsets."""
    t, lv = list(onsets.t_s), list(onsets.snr_db)
    kept = [float(x) for x in onsets.t_s[chain]]
    for tn, ln in zip(t_new, level_new):
        near = np.flatnonzero(np.abs(onsets.t_s - tn) < same_s)
        if near.size:
            kept.append(float(onsets.t_s[near[0]]))
        else:
            t.append(float(tn))
            lv.append(float(ln))
            kept.append(float(tn))
    order = np.argsort(t, kind="stable")
    t_all = np.asarray(t)[order]
    merged = Onsets(t_s=t_all, snr_db=np.asarray(lv)[order], noise_level=onsets.noise_level)
    return merged, np.searchsorted(t_all, kept)


def parse(path, *, progress=None, **_ignored):
    """The ``sound`` reader: impact times of a recording (see :func:`track_sound`)."""
    return track_sound(path, progress=progress).impacts
