"""One module per ``stereo-obstacles`` sub-command; see :mod:`stereo_obstacles.cli`."""
