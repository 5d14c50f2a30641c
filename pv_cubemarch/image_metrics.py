"""Image comparison for regression tests and accuracy reports.

:func:`compare_images` measures; :func:`assert_images_close` is the regression check, with
tolerances tight enough that a 5 % brightness change or a shift of a few pixels fails
(``tests/test_image_regression.py`` shows both), loose enough for driver rounding.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Regression tolerances (8-bit levels / fractions); see the module docstring.
MAX_MEAN_ERROR = 0.6
MAX_BAD_PIXEL_FRACTION = 0.002
BAD_PIXEL_LEVEL = 8
MIN_SSIM = 0.99


@dataclass(frozen=True)
class ImageErrors:
    """Differences between an image and its reference, in 8-bit levels where it applies."""

    mean_abs: float
    max_abs: float
    bad_pixel_fraction: float
    psnr: float
    ssim: float

    def as_dict(self) -> dict[str, float]:
        """The metrics by name (JSON-friendly)."""
        return {k: float(v) for k, v in self.__dict__.items()}


def to_uint8(image: np.ndarray) -> np.ndarray:
    """Round a float image in [0, 1] to uint8 the way GL writes a colour buffer."""
    if image.dtype == np.uint8:
        return image
    return np.clip(np.rint(np.asarray(image, dtype=np.float64) * 255.0), 0, 255).astype(np.uint8)


def compare_images(image: np.ndarray, reference: np.ndarray) -> ImageErrors:
    """Mean/max absolute error, bad-pixel fraction, PSNR and SSIM of RGB ``image``."""
    a, b = to_uint8(image), to_uint8(reference)
    if a.shape != b.shape:
        raise ValueError(f"Image shapes differ: {a.shape} vs reference {b.shape}.")
    from skimage.metrics import (  # here: scikit-image costs import pv_cubemarch 0.3 s
        peak_signal_noise_ratio,
        structural_similarity,
    )

    diff = np.abs(a.astype(np.int16) - b.astype(np.int16))
    per_pixel = diff.max(axis=-1)
    psnr = float("inf") if not diff.any() else float(peak_signal_noise_ratio(b, a, data_range=255))
    ssim = float(structural_similarity(b, a, channel_axis=-1, data_range=255))
    return ImageErrors(mean_abs=float(diff.mean()), max_abs=float(diff.max()),
                       bad_pixel_fraction=float((per_pixel > BAD_PIXEL_LEVEL).mean()),
                       psnr=psnr, ssim=ssim)


def images_match(errors: ImageErrors) -> bool:
    """Whether ``errors`` are within the regression tolerances."""
    return (errors.mean_abs <= MAX_MEAN_ERROR and errors.ssim >= MIN_SSIM
            and errors.bad_pixel_fraction <= MAX_BAD_PIXEL_FRACTION)


def assert_images_close(image: np.ndarray, reference: np.ndarray, what: str = "image") -> None:
    """Raise ``AssertionError`` naming the metric that failed."""
    errors = compare_images(image, reference)
    if not images_match(errors):
        raise AssertionError(f"{what} differs from its baseline: {errors.as_dict()} (limits: mean "
                             f"<= {MAX_MEAN_ERROR}, ssim >= {MIN_SSIM}, pixels off by more than "
                             f"{BAD_PIXEL_LEVEL} <= {MAX_BAD_PIXEL_FRACTION:.1%})")
