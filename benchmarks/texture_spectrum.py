"""How much fine texture a picture of a surface has: the slope β of its radially averaged power
spectrum and its fine share (benchmarks/bench_texture.py; docs/benchmarks.md, "Texture: β and
fine share"). Plain numpy, no bpy: the same function measures renders and synthetic images.

The measure, step by step (``spectrum_slope``):

1. **linear luminance** Y = 0.2126 R + 0.7152 G + 0.0722 B of linear RGB (Rec. 709); a 2-D
   array is taken as a luminance already (a ratio image);
2. **mean removed**;
3. a **2-D Hann window**, the outer product of two symmetric Hann windows (``np.hanning``: 0 at
   the edges), so that the jump between opposite edges of a crop, which the FFT takes as
   periodic, does not spread power over every frequency;
4. the power spectrum P = |FFT|² of the windowed image, at the frequencies
   f = sqrt(fx² + fy²) in cycles per pixel (``np.fft.fftfreq``);
5. its **radial average** in rings one frequency step wide: ring k holds the frequencies with
   round(f N) = k (N the shorter side, so k / N ± 1 / 2N), P(ring) their mean power and f(ring)
   their mean frequency (not k / N: the few frequencies of the inner rings are not centred);
6. **β** = minus the least-squares slope of ln P(ring) against ln f(ring) over the rings with
   1/32 <= k / N <= 1/4 (rings 8 to 64 of a 256-pixel crop), every ring weighted alike;
7. the **fine share**: the power at f > 1/16 over the power at every f > 0 (DC excluded: it is 0
   after step 2), summed over the 2-D spectrum (each frequency, not the rings). By Parseval this
   is the share of the *windowed* image's variance: the variance is measured after the window,
   since before it the crop's edges would add a jump's f⁻² spectrum to the fine band.

For white noise the fine share is the share of the frequency square [-1/2, 1/2)² outside the
disc f <= 1/16: 1 - π/256 = 0.988 (the window leaves white noise white). A constant image (no
variance left after step 2, to rounding) has no spectrum: β = 0 and fine share 0, by definition.
"""

import numpy as np

#: Rec. 709 luminance of linear RGB.
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
#: The frequencies (cycles per pixel) whose rings the slope is fitted over.
FIT_BAND = (1 / 32, 1 / 4)
#: Frequencies above this (cycles per pixel) are the fine band.
FINE_FROM = 1 / 16
#: Below this fraction of the image's scale (its largest |value|), a deviation from the mean is
#: rounding: the image counts as constant.
CONSTANT_BELOW = 1e-9


def luminance(image):
    """Linear luminance of (H, W, 3 or 4) linear RGB(A); a (H, W) array as it is."""
    image = np.asarray(image, dtype=np.float64)
    return image if image.ndim == 2 else image[..., :3] @ LUMINANCE


def power_spectrum(image):
    """(f, P): the frequency in cycles per pixel and the power |FFT|² of the luminance of
    ``image``, mean removed and Hann-windowed, both (H, W) in FFT order."""
    values = luminance(image)
    values = values - values.mean()
    window = np.outer(np.hanning(values.shape[0]), np.hanning(values.shape[1]))
    power = np.abs(np.fft.fft2(values * window)) ** 2
    fy, fx = np.meshgrid(np.fft.fftfreq(values.shape[0]), np.fft.fftfreq(values.shape[1]), indexing="ij")
    return np.hypot(fx, fy), power


def radial_average(frequency, power):
    """(k / N, f, P) of each ring k, one frequency step 1 / N wide (N the shorter side): its
    nominal frequency, and the mean frequency and mean power of the frequencies in it, for the
    rings that hold any, DC's ring left out."""
    step = 1.0 / min(frequency.shape)
    ring = np.rint(frequency / step).astype(int).ravel()
    counts = np.bincount(ring)
    held = np.nonzero(counts)[0]
    held = held[held > 0]
    mean_f = np.bincount(ring, frequency.ravel())[held] / counts[held]
    mean_p = np.bincount(ring, power.ravel())[held] / counts[held]
    return held * step, mean_f, mean_p


def spectrum_slope(image):
    """(β, fine share) of ``image`` (linear RGB(A) or a 2-D luminance), as the module says:
    β minus the slope of ln P against ln f over 1/32 <= f <= 1/4, the fine share the windowed
    variance at f > 1/16 over all of it. A constant image gives (0.0, 0.0)."""
    values = luminance(image)
    scale = float(np.abs(values).max()) if values.size else 0.0
    if not np.isfinite(scale):
        raise ValueError("the image has non-finite values")
    if values.size == 0 or np.ptp(values) <= CONSTANT_BELOW * max(scale, np.finfo(float).tiny):
        return 0.0, 0.0
    frequency, power = power_spectrum(values)
    nominal, ring_f, ring_p = radial_average(frequency, power)
    fitted = (nominal >= FIT_BAND[0]) & (nominal <= FIT_BAND[1])
    tiny = np.finfo(float).tiny  # a ring with no power (a pure tone's image) stays finite
    slope = np.polyfit(np.log(ring_f[fitted]), np.log(np.maximum(ring_p[fitted], tiny)), 1)[0]
    total = power[frequency > 0].sum()
    fine = power[frequency > FINE_FROM].sum()
    return float(-slope), float(fine / total) if total > 0 else 0.0


def fine_band_variance(image):
    """The windowed variance of ``image``'s luminance at f > 1/16 (the fine share's numerator,
    per pixel): what two renders of different seeds are compared by."""
    values = luminance(image)
    frequency, power = power_spectrum(values)
    return float(power[frequency > FINE_FROM].sum() / values.size**2)
