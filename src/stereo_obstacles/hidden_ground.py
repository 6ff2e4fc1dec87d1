"""Ground the right camera cannot see, matched anyway and raised above the ground plane.

Beside the left edge of a near object, the left camera sees a strip of ground that the object
hides from the right camera (its width in columns is the object's disparity minus the
ground's). No correct match exists there. The visibility test (:mod:`stereo_obstacles.visibility`)
removes a match whose own right-image column the near object covers, but it trusts the near
object's matches: where the object's leftmost columns went unmatched (a window straddling the
edge), the strip's pixels can be paired with right-image texture just beside the object and
land between the two depths, above the ground plane. Phase 1 calls them ground, their disparity
raises them (the pipeline's ground-coloured obstacle candidates), and they became an obstacle
of their own: a strip of shadow 10 x 48 px beside a box 1.54 m away, reported at 1.89 m
(``docs/pipeline.md``, "Ground beside a near object's left edge").

The test asks what the ground hypothesis predicts. A raised match at ``(x, y)`` with disparity
``d`` is *hidden ground* when

* it lies left of an occluding edge within reach: two neighbouring matches of its row (no match
  between them) at most ``max_edge_gap_px`` columns apart whose disparity rises by more than
  ``min_jump_px`` from left to right, the pixel at or left of the far side;
* were it ground, at the plane's disparity ``g = a x + b y + c > 0`` (below the horizon), the
  right camera would see it at column ``x - g``, and that column lies behind the edge's near
  side and is covered by a matched surface more than ``min_jump_px`` nearer than ``d``.

The right camera then cannot have seen this ground, so the match is no evidence that the pixel
is not ground. The edge is required because a face receding in depth covers its own ground
hypothesis: its nearer columns, further right, stand where its left columns' ground would be.

A ground-coloured object standing just left of a nearer one has the same geometry in a band as
wide as the ground's occlusion, so single pixels are not removed: an obstacle group is rejected
(with its reason) only when at least ``min_hidden_share`` of its matched pixels are hidden
ground. On scenes 0..269 of ``evaluate-detection`` that is the strip above alone (163 of its 256
pixels); the next largest share of a reported obstacle was 0.26, itself a false alarm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stereo_obstacles._hidden_ground_kernel import hidden_ground_kernel
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import check_integers, check_numbers
from stereo_obstacles.float_maps import check_float_map
from stereo_obstacles.ground_plane import GroundPlane
from stereo_obstacles.labels import Label
from stereo_obstacles.obstacles import RejectedGroup
from stereo_obstacles.visibility import VisibilityParameters

SURFACE = VisibilityParameters()
"""How neighbouring matches of a row join into one surface when the right-image cover is built:
as the visibility test joins them by default."""


@dataclass(frozen=True)
class HiddenGroundParameters:
    """When a raised group is ground the right camera cannot see.

    Attributes
    ----------
    min_jump_px : float
        An occluding edge rises by more than this many pixels of disparity between two
        neighbouring matches of a row, and the surface that hides the ground is more than this
        much nearer than the match.
    max_edge_gap_px : int
        Largest number of columns between the two matches of an edge (a near object's leftmost
        columns often go unmatched).
    min_hidden_share : float
        A group whose matched pixels are hidden ground in at least this share is rejected.
    """

    min_jump_px: float = 2.0
    max_edge_gap_px: int = 10
    min_hidden_share: float = 0.5

    def __post_init__(self) -> None:
        check_numbers(self, (("min_jump_px", 0.0, 1000.0), ("min_hidden_share", 0.0, 1.0)))
        check_integers(self, (("max_edge_gap_px", 1, 1000),))


def hidden_ground(disparity: np.ndarray, mask: np.ndarray, ground: GroundPlane,
                  params: HiddenGroundParameters = HiddenGroundParameters()) -> np.ndarray:
    """Which matches of ``mask`` would be ground hidden from the right camera (module docstring).

    Parameters
    ----------
    disparity
        ``float (H, W)`` left disparity in pixels, NaN (or inf) where unmatched; compared in
        ``float32``, as the visibility test compares it.
    mask
        ``bool (H, W)``: the matches to test (the pipeline's raised ground-coloured pixels).
    ground
        The ground plane in disparity space (pixels of disparity, without ``doffs``).
    params
        See :class:`HiddenGroundParameters`.

    Returns
    -------
    numpy.ndarray
        ``bool (H, W)``, True for the hidden ground; False elsewhere.

    Examples
    --------
    >>> from stereo_obstacles.ground_plane import GroundPlane
    >>> d = np.full((1, 80), 20.0, np.float32)     # ground at 20 px of disparity
    >>> d[0, 50:70] = 40.0                         # a near box from column 50 ...
    >>> d[0, 50:54] = np.nan                       # ... its first columns unmatched
    >>> d[0, 40:44] = 30.0                         # ground left of it matched too near
    >>> plane = GroundPlane(a=0.0, b=0.0, c=20.0, n_inliers=80, inlier_fraction=1.0, rms_px=0.0)
    >>> np.flatnonzero(hidden_ground(d, d == 30.0, plane)[0]).tolist()
    [40, 41, 42, 43]
    """
    d = check_float_map(disparity, "disparity")
    m = np.asarray(mask)
    if m.shape != d.shape or m.dtype != np.bool_:
        raise InvalidInputError(f"mask must be a bool map of the disparity's shape {d.shape}, got {m.dtype} {m.shape}")
    _check_kinds(ground, params)
    with np.errstate(over="ignore"):  # float64 beyond float32's range becomes inf: unmatched
        d32 = np.ascontiguousarray(d, dtype=np.float32)
    return hidden_ground_kernel(d32, np.ascontiguousarray(m), float(ground.a), float(ground.b), float(ground.c),
                                float(params.min_jump_px), int(params.max_edge_gap_px),
                                int(SURFACE.max_gap_px), float(SURFACE.surface_tolerance_px))


def reject_hidden_ground(groups: np.ndarray, disparity: np.ndarray, labels: np.ndarray, ground: GroundPlane,
                         params: HiddenGroundParameters = HiddenGroundParameters()
                         ) -> tuple[np.ndarray, tuple[RejectedGroup, ...]]:
    """The groups with those made mostly of hidden ground removed, and those listed as rejected.

    Parameters
    ----------
    groups
        ``int (H, W)`` group number per pixel, 0 (or negative) for none.
    disparity
        ``float (H, W)`` disparity in pixels, NaN where unmatched (a group's matched pixels are
        its pixels with a finite disparity).
    labels
        ``uint8 (H, W)`` phase-1 labels: the grouped pixels it does not call
        :attr:`~stereo_obstacles.labels.Label.OBSTACLE` (ground-coloured, raised by their
        disparity) are tested by :func:`hidden_ground`; colour obstacles are never hidden ground.
    ground
        The ground plane in disparity space.
    params
        See :class:`HiddenGroundParameters`; ``min_hidden_share`` of a group's matched pixels
        rejects it.

    Returns
    -------
    tuple
        ``(groups, rejected)``: a copy of ``groups`` with the rejected groups' pixels set to 0
        (``groups`` itself when none is), and one :class:`RejectedGroup` per rejected group.
    """
    g = np.asarray(groups)
    lab = np.asarray(labels)
    d = check_float_map(disparity, "disparity")
    if g.ndim != 2 or g.shape != d.shape or g.shape != lab.shape:
        raise InvalidInputError(f"groups {g.shape}, disparity {d.shape} and labels {lab.shape} "
                                f"must be the same 2-D shape")
    if not (np.issubdtype(g.dtype, np.integer) or g.dtype == np.bool_) or lab.dtype != np.uint8:
        raise InvalidInputError(f"groups must hold integers and labels be uint8, got {g.dtype} and {lab.dtype}")
    _check_kinds(ground, params)
    grouped = g > 0
    hidden = hidden_ground(d, grouped & (lab != Label.OBSTACLE.value), ground, params)
    matched = grouped & np.isfinite(d)
    numbers = g[matched]
    if int(numbers.max(initial=0)) < g.size:   # dense enough to count by number
        ids, index = np.arange(int(numbers.max(initial=0)) + 1), numbers
    else:  # compacted, so that sparse or huge numbers cost no more than dense ones
        ids, index = np.unique(numbers, return_inverse=True)
    n_matched = np.bincount(index, minlength=ids.size)
    n_hidden = np.bincount(index, weights=hidden[matched], minlength=ids.size).astype(np.int64)
    rejected_ids = ids[(n_hidden > 0) & (n_hidden >= params.min_hidden_share * n_matched)]
    if rejected_ids.size == 0:
        return g, ()
    rejected = []
    for group in rejected_ids:
        ys, xs = np.nonzero(g == group)
        box = (int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1)
        k = int(np.searchsorted(ids, group))
        rejected.append(RejectedGroup(box, int(xs.size), (
            f"ground beside a nearer object's left edge that the right camera cannot see "
            f"({n_hidden[k]} of {n_matched[k]} matched pixels): matches there are no evidence of an obstacle")))
    return np.where(np.isin(g, rejected_ids), 0, g), tuple(rejected)


def _check_kinds(ground: object, params: object) -> None:
    """One clear line for a ground plane or parameters of the wrong kind."""
    if not isinstance(ground, GroundPlane):
        raise InvalidInputError(f"ground must be a GroundPlane, got {type(ground).__name__}")
    if not isinstance(params, HiddenGroundParameters):
        raise InvalidInputError(f"params must be HiddenGroundParameters, got {type(params).__name__}")
