"""The dominant frequency of a periodic signal (a foot's lead over the other, a hand's swing): what the
cadence measures of `eval.metrics` and the transfer's starting tempo (`steps.tempo`) read."""

from __future__ import annotations

import numpy as np

from elastyle.types import FloatArray

MIN_CYCLES = 2.0  # a frequency is read only where the clip holds at least this many cycles of it


def dominant_frequency_hz(signal: FloatArray, fps: float, low_hz: float = 0.3, high_hz: float = 3.0) -> float:
    """The strongest frequency (Hz) of a signal (T,) sampled at `fps` within [low_hz, high_hz] (a Hann-windowed,
    zero-padded spectrum); NaN for fewer than 8 samples, a flat signal, or one shorter than `MIN_CYCLES` of
    it."""
    signal = signal - signal.mean()
    if signal.shape[0] < 8 or not np.any(signal):
        return float("nan")
    windowed = signal * np.hanning(signal.shape[0])
    size = max(8192, 1 << int(np.ceil(np.log2(signal.shape[0] * 8))))
    spectrum = np.abs(np.fft.rfft(windowed, n=size))
    frequencies = np.fft.rfftfreq(size, 1.0 / fps)
    band = (frequencies >= low_hz) & (frequencies <= high_hz)
    found = float(frequencies[band][np.argmax(spectrum[band])])
    # a clip shorter than a few cycles of it holds no rhythm to read (a 1 s clip's "cadence" was its length)
    return found if signal.shape[0] / fps * found >= MIN_CYCLES else float("nan")
