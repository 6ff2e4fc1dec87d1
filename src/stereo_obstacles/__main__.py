"""``python -m stereo_obstacles``: the same as the ``stereo-obstacles`` command."""

from stereo_obstacles.cli import main

raise SystemExit(main())
