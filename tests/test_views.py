"""Comparing two renders of a view: one exposure from the reference, Yee and FLIP on the
display images, against outcomes known beforehand."""
import numpy as np
import pytest

from native.output import tone_map
from native.evaluation.view_difference import MIDDLE_GREY, compare_views, exposure_for, failure_image


def ramp(height=96, width=128):
    """Linear radiance: a horizontal ramp of a warm grey, 0.05 to 1."""
    x = np.linspace(0.05, 1.0, width)
    return np.broadcast_to(x[None, :, None] * np.array([1.0, 0.9, 0.7]),
                           (height, width, 3)).copy()


def test_exposure_shows_the_log_average_luminance_as_middle_grey():
    image = np.zeros((4, 4, 3))
    image[:2] = 0.5     # luminance 0.5 on half the pixels, 2.0 on the rest
    image[2:] = 2.0
    assert exposure_for(image) == pytest.approx(MIDDLE_GREY / 1.0)
    assert exposure_for(np.zeros((4, 4, 3))) == 1.0


def test_identical_views_do_not_differ():
    comparison = compare_views(ramp(), ramp())
    assert comparison.yee.failed_pixels == 0 and not comparison.yee.different
    assert comparison.flip.mean == 0.0
    np.testing.assert_array_equal(comparison.reference_display, comparison.test_display)


def test_both_views_take_the_reference_exposure():
    """A test view twice as bright is shown twice as bright, not re-exposed to match."""
    reference = ramp()
    comparison = compare_views(reference, 2.0 * reference)
    exposure = exposure_for(reference)
    np.testing.assert_array_equal(comparison.reference_display, tone_map(reference, exposure))
    np.testing.assert_array_equal(comparison.test_display, tone_map(2.0 * reference, exposure))
    assert comparison.yee.different and comparison.flip.mean > 0.05


def test_a_small_bright_patch_is_found_where_it_is():
    reference = ramp()
    test = reference.copy()
    test[40:56, 60:76] *= 3.0
    comparison = compare_views(reference, test)
    failed = comparison.yee.failed
    assert failed[44:52, 64:72].all()
    assert not failed[:, :40].any() and not failed[:, 100:].any()
    flip = comparison.flip.error
    assert flip[40:56, 60:76].mean() > 10 * flip[:, :40].mean()


def test_failure_image_marks_failed_pixels_red_on_grey():
    display = np.full((4, 4, 3), 200, dtype=np.uint8)
    failed = np.zeros((4, 4), bool)
    failed[1, 2] = True
    image = failure_image(display, failed)
    assert tuple(image[1, 2]) == (255, 0, 0)
    assert (image[~failed] == image[~failed][:, :1]).all()     # grey elsewhere
    assert image[0, 0, 0] < 200
