"""Figures of every command, drawn with matplotlib (PNG, PDF or SVG; no display needed).

* :mod:`~nightloc.figures.evaluation` — ``nightloc evaluate`` / ``demo``: error box plots, heat map;
* :mod:`~nightloc.figures.route` — ``nightloc route``: difference matrix, PR curve, matches;
* :mod:`~nightloc.figures.synth` — the synthetic worlds: map and day/night panoramas;
* :mod:`~nightloc.figures.trajectory` — a localized traverse (``nightloc localize``): the
  estimated trajectory on the map and the error per frame.

Each figure function returns a :class:`matplotlib.figure.Figure` (made without pyplot, so it
draws in scripts, servers and notebooks alike) and writes it atomically when given a path.
Importing this package does not import matplotlib; its modules do, and nothing on the robot's
path (:class:`nightloc.Localizer`, :func:`nightloc.match`, :func:`nightloc.prepare`, the route
localizer) imports them.
"""

from __future__ import annotations

import argparse

__all__ = ["FORMATS", "add_figure_format_option"]

#: File formats of the figures (``--figure-format``).
FORMATS = ("png", "pdf", "svg")


def add_figure_format_option(parser: argparse.ArgumentParser) -> None:
    """Adds ``--figure-format png|pdf|svg`` (default png) to a command that writes figures."""
    parser.add_argument(
        "--figure-format",
        choices=FORMATS,
        default="png",
        help="file format of the figures (default png)",
    )
