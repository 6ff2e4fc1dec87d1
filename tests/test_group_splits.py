"""GroupSplits: the parts of split groups written into a copy of the group map."""

from __future__ import annotations

import numpy as np

from stereo_obstacles.group_splits import GroupSplits


def test_new_parts_are_numbered_after_every_label_in_turn():
    groups = np.array([[0, 0, 0, 1, 1, 1, -1]], dtype=np.int64)
    splits = GroupSplits(groups, n_groups=2)
    splits.split(0, np.zeros(3, int), np.arange(3), np.array([0, 1, 2]))
    splits.split(1, np.zeros(3, int), np.arange(3, 6), np.array([1, 1, 0]))
    assert splits.groups.tolist() == [[0, 2, 3, 4, 4, 1, -1]]
    assert groups.tolist() == [[0, 0, 0, 1, 1, 1, -1]]


def test_a_group_left_in_one_part_leaves_the_map_uncopied():
    groups = np.array([[0, 0, 1]], dtype=np.int64)
    splits = GroupSplits(groups, n_groups=2)
    splits.split(0, np.zeros(2, int), np.arange(2), np.zeros(2, int))
    assert splits.groups is groups
