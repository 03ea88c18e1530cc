"""How out of focus a photograph is.

The detectors' statistics, the pose search's edge thresholds and the calibration
were all made on sharp renders (their edges about 0.5 px wide, one Gaussian
sigma). A photograph out of focus by 2-3 px spreads every edge over several
pixels: edge strengths fall below the thresholds, silhouettes blur into one
another and the polish drifts (2.3 mm median from the true pose on renders
defocused by 1.5-3 px, against 0.6 mm on sharp ones). :func:`estimate_defocus`
measures the blur from the image itself: the ratio of gradient magnitudes at two
scales at its strongest edges (a step edge blurred by ``s`` and smoothed by ``a``
has a peak gradient ∝ ``1/sqrt(s² + a²)``; Zhuo and Sim's defocus estimate). The
pipeline warns when it exceeds :data:`DEFOCUS_WARN_PX`. Sharpening such a
photograph (a Wiener deconvolution by the measured blur) was tried and made the
estimates worse: it amplifies noise the detectors never saw (docs/decisions.md).

Examples
--------
>>> import cv2
>>> sharp = np.zeros((120, 160, 3), np.uint8)
>>> for x in range(10, 160, 24):
...     sharp[:, x:x + 12] = 200
>>> estimate_defocus(sharp) < DEFOCUS_WARN_PX
True
>>> estimate_defocus(cv2.GaussianBlur(sharp, (0, 0), 2.5)) > DEFOCUS_WARN_PX
True
"""

from __future__ import annotations

import cv2
import numpy as np

from unseeable.errors import InputError

__all__ = ["estimate_defocus", "added_blur", "DEFOCUS_WARN_PX"]

#: Blur (Gaussian sigma, px, as :func:`estimate_defocus` measures it) above which a
#: photograph is reported out of focus. The sharp renders the calibration was made on
#: measure 0-0.7 px; the same blurred by 1.5 px measure about 1.4 (:func:`added_blur`).
DEFOCUS_WARN_PX = 1.2
#: What :func:`estimate_defocus` reads, ``e``, against the Gaussian blur added to a sharp
#: render, ``s``: ``s ≈ slope * e + offset`` (training renders blurred by 1-3.5 px; the
#: estimate reads low where the blur is large against its own scales).
_ADDED_BLUR = (1.2, -0.19)
#: The smoothing scales of the two gradients whose ratio measures the blur.
_SCALES = (1.0, 2.0)
#: Share of the image's pixels, the strongest gradients, that the blur is measured at.
_EDGE_SHARE = 0.02


def _gradient(gray: np.ndarray, sigma: float) -> np.ndarray:
    g = cv2.GaussianBlur(gray, (0, 0), sigma)
    gx = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3)
    return np.hypot(gx, gy)


def _check_rgb(image: np.ndarray) -> np.ndarray:
    arr = np.asarray(image)
    if arr.ndim != 3 or arr.shape[2] != 3 or arr.dtype != np.uint8:
        raise InputError("must be an (H, W, 3) uint8 RGB image", field="image",
                         value=(arr.shape, str(arr.dtype)))
    return arr


def estimate_defocus(image: np.ndarray) -> float:
    """How blurred an image is: the Gaussian sigma (px) of its sharpest edges' blur.

    Parameters
    ----------
    image : (H, W, 3) uint8
        RGB.

    Returns
    -------
    float
        The median over the strongest gradient maxima (:data:`_EDGE_SHARE` of the
        pixels); 0 for an image without edges.
    """
    arr = _check_rgb(image)
    gray = cv2.cvtColor(np.ascontiguousarray(arr), cv2.COLOR_RGB2GRAY).astype(np.float32)
    a1, a2 = _SCALES
    g1, g2 = _gradient(gray, a1), _gradient(gray, a2)
    if not np.any(g1 > 0):
        return 0.0
    peaks = (g1 >= cv2.dilate(g1, np.ones((3, 3), np.uint8))) \
        & (g1 >= np.quantile(g1, 1.0 - _EDGE_SHARE)) & (g1 > 0)
    ratio = g1[peaks] / np.maximum(g2[peaks], 1e-6)
    ratio = ratio[ratio > 1.0 + 1e-3]
    if not len(ratio):
        return 0.0
    squared = (a2 ** 2 - ratio ** 2 * a1 ** 2) / (ratio ** 2 - 1.0)
    return float(np.median(np.sqrt(np.clip(squared, 0.0, None))))


def added_blur(measured: float) -> float:
    """The Gaussian blur (px) beyond a sharp render's that :func:`estimate_defocus`'s
    reading ``measured`` stands for (0 below :data:`DEFOCUS_WARN_PX`).

    >>> added_blur(0.5), round(added_blur(2.0), 2)
    (0.0, 2.21)
    """
    if measured <= DEFOCUS_WARN_PX:
        return 0.0
    return float(_ADDED_BLUR[0] * measured + _ADDED_BLUR[1])
