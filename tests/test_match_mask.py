"""refine.match_mask: the flow matches' erosion keeps a core of every silhouette."""
import cv2
import numpy as np

from ycbvss.refine.match_mask import match_erosion_px, match_mask


def _bar(width_px: int, angle_deg: float = 0.0) -> np.ndarray:
    """A 120 px long bar ``width_px`` wide, turned by ``angle_deg``, on a 200 x 200 image."""
    m = np.zeros((200, 200), np.uint8)
    box = cv2.boxPoints(((100.0, 100.0), (120.0, float(width_px)), angle_deg))
    cv2.fillPoly(m, [np.round(box).astype(np.int32)], 1)
    return m > 0


def _fixed(mask: np.ndarray, e: int) -> np.ndarray:
    return cv2.erode(mask.astype(np.uint8), np.ones((2 * e + 1, 2 * e + 1), np.uint8)) > 0


def test_thin_bar_keeps_a_core_the_fixed_erosion_removes():
    # the large marker at 1.4 m: about 13 px across
    for angle in (0.0, 30.0):
        m = _bar(13, angle)
        assert _fixed(m, 6).sum() <= 0.1 * m.sum()           # the fixed 6 px erosion: (almost) nothing left
        e = match_erosion_px(m, 6, 3)
        assert 2 <= e <= 4, e
        kept = match_mask(m, 6, 3)
        assert kept.sum() >= 0.15 * m.sum()                  # a core of the bar remains (a 5 px strip)
        # ... and none of it within e px of the outline
        dist = cv2.distanceTransform(np.pad(m, 1).astype(np.uint8), cv2.DIST_L2, 5)[1:-1, 1:-1]
        assert dist[kept].min() > e


def test_thick_silhouette_is_eroded_as_before():
    m = np.zeros((200, 200), np.uint8)
    cv2.circle(m, (100, 100), 40, 1, -1)
    m = m > 0
    assert match_erosion_px(m, 6, 3) == 6
    np.testing.assert_array_equal(match_mask(m, 6, 3), _fixed(m, 6))


def test_core_zero_is_the_fixed_erosion_and_edge_cases():
    m = _bar(13)
    np.testing.assert_array_equal(match_mask(m, 6, 0), _fixed(m, 6))
    assert match_erosion_px(m, 0, 3) == 0
    assert not match_mask(np.zeros((20, 20), bool), 6, 3).any()
    one = np.zeros((20, 20), bool)
    one[10, 5:15] = True                                     # a 1 px line: at least 1 px eroded, nothing left
    assert match_erosion_px(one, 6, 3) == 1
    assert not match_mask(one, 6, 3).any()
