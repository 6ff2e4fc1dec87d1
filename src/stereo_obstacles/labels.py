"""The pixel classes shared by the segmentation, the synthetic ground truth and the reports.

Values are stored in ``uint8`` label images (PNG). Segmentation produces ``UNKNOWN``,
``GROUND``, ``SHADOW`` and ``OBSTACLE``; the synthetic world's ground truth also uses
``MARKING`` (a flat marking painted on the ground) and ``SKY`` (background beyond the ground).
"""

from __future__ import annotations

from enum import IntEnum

import numpy as np


class Label(IntEnum):
    """Class of a pixel. ``SHADOW`` is ground in cast shadow and counts as ground.

    Compare label images with ``.value`` (``labels == Label.OBSTACLE.value``): NumPy promotes an
    ``IntEnum`` member to ``int64``, so ``labels == Label.OBSTACLE`` first casts the whole
    ``uint8`` image (0.10 against 0.008 ms at 640x480, a scratch measurement)."""

    UNKNOWN = 0
    GROUND = 1
    SHADOW = 2
    OBSTACLE = 3
    MARKING = 4
    SKY = 5


SEGMENTATION_LABELS = (Label.UNKNOWN, Label.GROUND, Label.SHADOW, Label.OBSTACLE)
"""The classes phase 1 gives a pixel (``MARKING`` and ``SKY`` are the ground truth's only)."""


LABEL_COLOURS_RGB: dict[Label, tuple[int, int, int]] = {
    Label.UNKNOWN: (0, 0, 0),
    Label.GROUND: (60, 170, 60),
    Label.SHADOW: (60, 90, 200),
    Label.OBSTACLE: (220, 40, 40),
    Label.MARKING: (240, 220, 60),
    Label.SKY: (150, 200, 240),
}
"""Display colour of each label in pictures and overlays."""


def colorize_labels(labels: np.ndarray) -> np.ndarray:
    """Map a ``uint8 (H, W)`` label image to an RGB ``uint8 (H, W, 3)`` picture."""
    palette = np.zeros((256, 3), dtype=np.uint8)
    for label, rgb in LABEL_COLOURS_RGB.items():
        palette[int(label)] = rgb
    return palette[np.asarray(labels, dtype=np.uint8)]
