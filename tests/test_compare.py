"""Lightmap error measures against closed forms."""
import numpy as np
import pytest

from native.evaluation.texel_error import error_map, lightmap_error, texel_noise


def page(rgb, mask):
    return np.concatenate([rgb, mask[..., None].astype(np.float32)], axis=2).astype(np.float32)


def test_identical_lightmaps_have_no_error():
    rng = np.random.default_rng(1)
    reference = page(rng.random((16, 16, 3)), rng.random((16, 16)) > 0.3)
    error = lightmap_error([reference], [reference.copy()])
    assert error.rms == 0.0 and error.max_error == 0.0 and error.relative_rms == 0.0


def test_a_known_perturbation_gives_its_analytic_rms():
    """Adding (d, d, d) to a quarter of the compared texels: every difference has length
    d sqrt(3), so RMS = d sqrt(3) / 2 and the maximum d sqrt(3); texels outside the masks
    (either one) do not count, however wrong."""
    mask = np.zeros((8, 8), bool)
    mask[:, :4] = True
    reference = page(np.full((8, 8, 3), 0.5), mask)
    luxel = reference.copy()
    d = 0.2
    luxel[:2, :4, :3] += d          # 8 of the 32 compared texels
    luxel[:, 4:, :3] = 100.0        # outside the masks
    error = lightmap_error([luxel], [reference])
    assert error.texels == 32
    assert error.rms == pytest.approx(d * np.sqrt(3) / 2)
    assert error.max_error == pytest.approx(d * np.sqrt(3))
    assert error.relative_rms == pytest.approx(error.rms / (0.5 * np.sqrt(3)))
    assert error.reference_rms == pytest.approx(0.5 * np.sqrt(3))


def test_mismatched_or_disjoint_lightmaps_are_refused():
    a = page(np.zeros((4, 4, 3)), np.ones((4, 4), bool))
    with pytest.raises(ValueError, match="reference"):
        lightmap_error([a], [page(np.zeros((4, 5, 3)), np.ones((4, 5), bool))])
    with pytest.raises(ValueError, match="no texel"):
        lightmap_error([a], [page(np.zeros((4, 4, 3)), np.zeros((4, 4), bool))])


def test_error_map_runs_from_black_to_white_and_greys_out_unmasked_texels():
    reference = page(np.zeros((1, 4, 3)), np.array([[True, True, True, False]]))
    luxel = reference.copy()
    luxel[0, 1, :3] = 0.5 / np.sqrt(3)   # half the scale: the middle stop, green
    luxel[0, 2, :3] = 10.0               # beyond the scale: white
    colours = error_map(luxel, reference, scale=1.0)
    np.testing.assert_allclose(colours[0, 0, :3], [0, 0, 0])
    np.testing.assert_allclose(colours[0, 1, :3], [0, 1, 0], atol=1e-6)
    np.testing.assert_allclose(colours[0, 2, :3], [1, 1, 1])
    np.testing.assert_allclose(colours[0, 3, :3], [0.5, 0.5, 0.5])


def test_texel_noise_recovers_the_standard_deviation_of_added_noise():
    """Independent Gaussian noise of known sigma per channel on linear lighting: the estimate
    is sigma (within the sampling error of ~100 k triples), also with a hard shadow edge
    across the page; without noise it is 0."""
    y, x = np.mgrid[0:256, 0:256]
    lighting = np.stack([0.2 + 0.001 * x, 0.1 + 0.002 * y, 0.3 + 0.001 * (x + y)], axis=2)
    mask = np.ones((256, 256), bool)
    mask[100:120, :] = False        # triples across the hole are not used
    assert np.allclose(texel_noise(lighting, mask), 0.0, atol=1e-12)
    sigma = np.array([0.01, 0.02, 0.05])
    noisy = lighting + np.random.default_rng(3).normal(size=lighting.shape) * sigma
    noisy[100:120, :] = 1e6         # outside the mask: must not count
    noisy[:, 200:] -= 0.5           # a hard shadow: its edge is not noise
    np.testing.assert_allclose(texel_noise(noisy, mask), sigma, rtol=0.02)
    assert np.isnan(texel_noise(noisy, np.zeros_like(mask))).all()
