"""Yee's perceptual metric (pdiff): what it must flag, what it must let pass."""
import numpy as np
import pytest

from native.evaluation.perceptual import compare, csf, tvi

GAMMA = 2.2
# Y row of the Adobe RGB (1998) -> XYZ matrix (Lindbloom), which pdiff's luminance uses.
Y_ROW = np.array([0.297361, 0.627355, 0.0752847])


def grey(value, size=256):
    return np.full((size, size, 3), value)


def encode(linear):
    """Linear RGB -> the gamma-encoded display values the metric takes."""
    return np.asarray(linear, dtype=np.float64) ** (1.0 / GAMMA)


def test_identical_images_pass():
    rng = np.random.default_rng(1)
    image = rng.random((128, 160, 3))
    result = compare(image, image.copy())
    assert result.failed_pixels == 0
    assert result.fraction == 0.0
    assert not result.different
    assert result.failed.shape == (128, 160) and result.failed.dtype == bool


def test_bright_square_is_flagged_where_it_is():
    base = grey(0.5)
    changed = base.copy()
    changed[96:160, 96:160] = 1.0
    result = compare(base, changed)
    assert result.different
    square = np.zeros((256, 256), bool)
    square[96:160, 96:160] = True
    # Nearly all of the square fails; nothing far from it does.
    assert result.failed[square].mean() > 0.9
    far = np.ones((256, 256), bool)
    far[80:176, 80:176] = False
    assert not result.failed[far].any()


def test_half_image_fifty_percent_brighter_is_flagged():
    base = grey(0.5)
    changed = base.copy()
    changed[:, 128:] = encode(0.5 ** GAMMA * 1.5)
    result = compare(base, changed)
    assert result.different
    assert result.failed[:, 128:].mean() > 0.9
    assert result.failed[:, :120].sum() == 0


def test_uniform_half_percent_brightening_passes():
    base = grey(0.5)
    brighter = encode(np.full((256, 256, 3), 0.5 ** GAMMA * 1.005))
    result = compare(base, brighter)
    assert result.failed_pixels == 0
    assert not result.different


def test_one_level_grey_noise_passes():
    rng = np.random.default_rng(7)
    noise = rng.integers(-1, 2, size=(256, 256, 1)) / 255.0
    noisy = np.repeat(0.5 + noise, 3, axis=2)
    result = compare(grey(0.5), noisy)
    assert not result.different
    assert result.fraction < 0.001


def equal_luminance_patches(size=128):
    """A reddish and a greenish image of the same Adobe RGB luminance (Y = 0.25)."""
    blue = 0.1
    red = np.array([0.6, 0.0, blue])
    red[1] = (0.25 - Y_ROW[0] * red[0] - Y_ROW[2] * blue) / Y_ROW[1]
    green = np.array([0.0, 0.3, blue])
    green[0] = (0.25 - Y_ROW[1] * green[1] - Y_ROW[2] * blue) / Y_ROW[0]
    assert Y_ROW @ red == pytest.approx(Y_ROW @ green)
    assert (red >= 0).all() and (green >= 0).all() and red[0] > green[0] and green[1] > red[1]
    shape = (size, size, 3)
    return encode(np.broadcast_to(red, shape)), encode(np.broadcast_to(green, shape))


def test_equal_luminance_colour_change_is_caught_by_the_colour_test():
    red, green = equal_luminance_patches()
    result = compare(red, green)
    assert result.different
    assert result.failed.all()


def test_equal_luminance_colour_change_passes_without_the_colour_test():
    red, green = equal_luminance_patches()
    result = compare(red, green, color_factor=0.0)
    assert result.failed_pixels == 0
    assert not result.different


def test_colour_test_is_off_in_scotopic_light():
    # At 10 cd/m^2 display white the 25 cd/m^2 patches adapt to 2.5: pdiff sees no colour there.
    red, green = equal_luminance_patches()
    assert compare(red, green, luminance=10.0).failed_pixels == 0


def test_tvi_is_weber_in_photopic_light():
    # Ward Larson: above 10^1.9 cd/m^2 the threshold is a constant fraction, 10^-1.255.
    for adaptation in (100.0, 1000.0, 1e4):
        assert tvi(adaptation) == pytest.approx(adaptation * 10 ** -1.255)
    assert tvi(1e-5) == pytest.approx(10 ** -2.86)


def test_csf_peaks_where_pdiff_normalises_it():
    frequencies = np.linspace(0.5, 20.0, 3901)
    peak = frequencies[np.argmax(csf(frequencies, 100.0))]
    assert peak == pytest.approx(3.248, abs=0.1)


def test_downsample_halves_the_failure_map():
    base = grey(0.5)
    changed = base.copy()
    changed[64:128, 64:128] = 1.0
    result = compare(base, changed, downsample=1)
    assert result.failed.shape == (128, 128)
    assert result.failed[32:64, 32:64].mean() > 0.9


def test_shape_mismatch_raises():
    with pytest.raises(ValueError, match="shape"):
        compare(grey(0.5, 128), grey(0.5, 64))
    with pytest.raises(ValueError, match="RGB"):
        compare(np.zeros((32, 32)), np.zeros((32, 32)))
