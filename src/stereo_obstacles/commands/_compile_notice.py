"""A word on stderr before a command's work when numba must compile the kernels first.

numba compiles the kernels on their first use after an install or upgrade (about 30-35 s on a
2-core machine) and loads them from its on-disk cache afterwards (0.3-0.5 s). Without a word the
first run looks hung.
"""

from __future__ import annotations

import importlib
import sys

NOTICE = ("stereo-obstacles: compiling the numba kernels first (about 30 s after installing or upgrading; "
          "cached afterwards) ...")

SENTINEL_KERNELS = (
    ("_growing_kernel", "_grow_kernel"),                    # matching
    ("_stable_matching_kernel", "_stable_matching_kernel"),
    ("_refinement_kernel", "_refine_rows"),                 # the full-size refinement
    ("_ground_colour_kernel", "lookup_kernel"),             # phase 1 (the default colour model)
    ("_segmentation_kernel", "classify_modes_kernel"),
    ("_obstacle_grouping_kernel", "cell_medians_kernel"),   # phase 3
    ("_colour_split_kernel", "two_colours_kernel"),
    ("_obstacles_kernel", "patch_medians_kernel"),
)
"""One compiled kernel of each stage of ``detect`` (module, function): the ones that must be in
numba's cache for a run not to compile. (Not every kernel of the package: some serve other
commands only, and helpers compiled into their callers are never cached themselves.)"""


def kernels_cached() -> bool | None:
    """Whether numba's on-disk cache holds an up-to-date copy of every :data:`SENTINEL_KERNELS`;
    ``None`` when that cannot be told: numba's JIT is off (``NUMBA_DISABLE_JIT=1``: nothing is
    compiled), the cache is off (``STEREO_OBSTACLES_NUMBA_CACHE=0``), or its layout is unknown."""
    from numba.core.config import DISABLE_JIT

    from stereo_obstacles._similarity_kernel import CACHE

    if DISABLE_JIT or not CACHE:
        return None
    try:
        for module_name, name in SENTINEL_KERNELS:
            kernel = getattr(importlib.import_module(f"stereo_obstacles.{module_name}"), name)
            if not kernel._cache._cache_file._load_index():   # empty: absent, or stale after a change
                return False
    except Exception:  # noqa: BLE001 - numba's cache layout is not a public API
        return None
    return True


def announce_compilation() -> None:
    """Print :data:`NOTICE` on stderr when :func:`kernels_cached` says the kernels must be compiled."""
    if kernels_cached() is False:
        print(NOTICE, file=sys.stderr, flush=True)
