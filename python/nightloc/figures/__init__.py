"""Figures of every command (PNG files); nothing on the robot's path imports this package.

* :mod:`~nightloc.figures.evaluation` — ``nightloc evaluate`` / ``demo``: error box plots, heat map;
* :mod:`~nightloc.figures.route` — ``nightloc route``: difference matrix, PR curve, matches;
* :mod:`~nightloc.figures.synth` — ``nightloc synth``: the world's map and day/night panoramas.
"""
