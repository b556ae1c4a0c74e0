"""The texture measure of benchmarks/bench_texture.py (benchmarks/texture_spectrum.py) on images
whose answer is known: random-phase fields of a given spectral slope, white noise, constants."""

import numpy as np
import pytest

from benchmarks import texture_spectrum

SIDE = 256


def frequencies(side=SIDE):
    fy, fx = np.meshgrid(np.fft.fftfreq(side), np.fft.fftfreq(side), indexing="ij")
    return np.hypot(fx, fy)


def field_of_slope(beta, seed, side=SIDE):
    """A random-phase image whose spectrum's amplitude is f^(-β/2): its power falls as f^-β."""
    f = frequencies(side)
    amplitude = np.zeros_like(f)
    amplitude[f > 0] = f[f > 0] ** (-beta / 2)
    phase = np.exp(2j * np.pi * np.random.default_rng(seed).random(f.shape))
    return np.real(np.fft.ifft2(amplitude * phase))


@pytest.mark.parametrize("beta", [1.5, 2.5, 3.5])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_known_slope_is_recovered(beta, seed):
    measured, _ = texture_spectrum.spectrum_slope(field_of_slope(beta, seed))
    assert measured == pytest.approx(beta, abs=0.15)


def test_the_slope_is_of_the_luminance_of_linear_rgb():
    """The same field in the green channel only and as a grey: the same β (the Rec. 709 weight
    scales the power, not its slope); the fine share of a steep field is small."""
    field = field_of_slope(2.5, 3)
    green = np.zeros((SIDE, SIDE, 4))
    green[..., 1] = field + 1.0
    grey = np.repeat(field[..., None], 3, axis=2) + 0.5
    beta_green, fine_green = texture_spectrum.spectrum_slope(green)
    beta_grey, fine_grey = texture_spectrum.spectrum_slope(grey)
    assert beta_green == pytest.approx(beta_grey, abs=1e-9) and fine_green == pytest.approx(fine_grey, abs=1e-9)
    assert fine_grey < 0.1


def test_white_noise_has_the_fine_band_share_of_the_frequency_square():
    """White noise's power is flat: its fine share is the share of the frequencies above 1/16
    (1 - π/256 of the square [-1/2, 1/2)²), and its β is 0 (one draw's rings scatter: β within
    ±0.25, 3 standard deviations of it over draws)."""
    noise = np.random.default_rng(4).normal(size=(SIDE, SIDE))
    beta, fine = texture_spectrum.spectrum_slope(noise)
    f = frequencies()
    share = (f > texture_spectrum.FINE_FROM).sum() / (f.size - 1)
    assert share == pytest.approx(1 - np.pi / 256, abs=1e-3)
    assert fine == pytest.approx(share, abs=0.005)
    assert beta == pytest.approx(0.0, abs=0.25)


def test_a_smooth_field_has_little_fine_share_and_noise_on_it_raises_it():
    smooth = field_of_slope(4.0, 5)
    _, fine_smooth = texture_spectrum.spectrum_slope(smooth)
    noisy = smooth + 0.5 * smooth.std() * np.random.default_rng(6).normal(size=smooth.shape)
    _, fine_noisy = texture_spectrum.spectrum_slope(noisy)
    assert fine_smooth < 0.02 < 0.1 < fine_noisy


@pytest.mark.parametrize("image", [np.zeros((SIDE, SIDE)), np.full((SIDE, SIDE, 4), 0.3), np.full((64, 64), 1e6)])
def test_a_constant_image_has_no_spectrum(image):
    """Documented: (0, 0), never NaN."""
    assert texture_spectrum.spectrum_slope(image) == (0.0, 0.0)


def test_a_constant_image_with_rounding_noise_counts_as_constant():
    image = np.full((SIDE, SIDE), 0.1) + 1e-17 * np.random.default_rng(7).random((SIDE, SIDE))
    assert texture_spectrum.spectrum_slope(image) == (0.0, 0.0)


def test_non_finite_pixels_are_refused():
    image = np.zeros((SIDE, SIDE))
    image[3, 4] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        texture_spectrum.spectrum_slope(image)


def test_the_fine_band_variance_of_two_seeds_of_noise():
    """Two draws of the same white noise differ by twice its fine-band variance (what the
    benchmark's convergence check compares the renders' fine band with)."""
    rng = np.random.default_rng(8)
    a, b = rng.normal(size=(2, SIDE, SIDE))
    assert texture_spectrum.fine_band_variance(a - b) == pytest.approx(
        2 * texture_spectrum.fine_band_variance(a), rel=0.05
    )
