"""A short video: the rig walking straight ahead through a static scene."""

from __future__ import annotations

import math
from collections.abc import Iterator

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.synthetic.render import RenderOptions, SyntheticPair, render_pair
from stereo_obstacles.synthetic.scene import Scene


def render_sequence(scene: Scene, n_frames: int, speed_m_per_frame: float,
                    options: RenderOptions | None = None) -> Iterator[SyntheticPair]:
    """Render ``n_frames`` pairs with the rig ``k * speed_m_per_frame`` metres forward in frame ``k``.

    Parameters
    ----------
    scene : Scene
        The static world; obstacles keep their world positions, so their distances shrink.
    n_frames : int
        Number of frames (1..10000).
    speed_m_per_frame : float
        Forward motion between frames in metres (0..5; a walker at 1.4 m/s filmed at
        30 fps moves about 0.05 m per frame).
    options : RenderOptions, optional
        Imaging options, the same for every frame; the noise differs per frame.

    Yields
    ------
    SyntheticPair
        Frame ``k`` has ``forward_m = k * speed_m_per_frame``.

    Examples
    --------
    >>> from stereo_obstacles.synthetic import default_scene, render_sequence
    >>> frames = list(render_sequence(default_scene(64, 48), 2, 0.5))
    >>> [f.forward_m for f in frames]
    [0.0, 0.5]
    """
    if not isinstance(n_frames, int) or isinstance(n_frames, bool) or not 1 <= n_frames <= 10000:
        raise InvalidInputError(f"n_frames must be an integer in [1, 10000], got {n_frames!r}")
    if not (isinstance(speed_m_per_frame, (int, float)) and math.isfinite(speed_m_per_frame)
            and 0.0 <= speed_m_per_frame <= 5.0):
        raise InvalidInputError(f"speed_m_per_frame must be in [0, 5] metres, got {speed_m_per_frame!r}")
    return (render_pair(scene, options, forward_m=k * float(speed_m_per_frame), frame=k)
            for k in range(n_frames))
