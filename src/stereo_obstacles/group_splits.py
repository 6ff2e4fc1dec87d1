"""Writing the parts of split obstacle groups into a group map.

Both splits of :mod:`stereo_obstacles.obstacle_grouping` (into depth layers, and by colour in
:mod:`stereo_obstacles.colour_split`) divide some groups of a map into parts: the first part
keeps the group's label, the others take new labels after every label the map had.
"""

from __future__ import annotations

import numpy as np


class GroupSplits:
    """A group map (``int64 (H, W)``, labels ``0..n_groups-1``, -1 for none) with groups split
    into parts; the map given is left as it is (copied at the first split).

    >>> groups = np.array([[0, 0, 1, 1]])
    >>> splits = GroupSplits(groups, n_groups=2)
    >>> splits.split(1, np.array([0, 0]), np.array([2, 3]), np.array([0, 1]))
    >>> splits.groups.tolist(), groups.tolist()
    ([[0, 0, 1, 2]], [[0, 0, 1, 1]])
    """

    def __init__(self, groups: np.ndarray, n_groups: int) -> None:
        self._given = groups
        self.groups = groups
        self._next_label = n_groups

    def split(self, group: int, ys: np.ndarray, xs: np.ndarray, parts: np.ndarray) -> None:
        """Split ``group`` whose pixels are ``(ys, xs)`` into ``parts`` (``int (n,)``, ``0..k-1``
        for each pixel, every part present); one part leaves the map as it was."""
        n_parts = int(parts.max()) + 1
        if n_parts == 1:
            return
        if self.groups is self._given:
            self.groups = self._given.copy()
        new_labels = np.concatenate([[group], np.arange(self._next_label, self._next_label + n_parts - 1)])
        self.groups[ys, xs] = new_labels[parts]
        self._next_label += n_parts - 1
