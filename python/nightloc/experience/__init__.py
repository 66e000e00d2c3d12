"""Experience maps: a map that learns from its nights.

* :mod:`~nightloc.experience.learning` — :func:`localize_night` (a night localized over a map, every
  frame's estimate kept; :class:`NightLearner` frame by frame) and :func:`learn` (the map plus what the night taught it:
  :class:`LearningParams`, TOML ``[learning]``; :class:`LearningReport`).

This stage sits above localization (it runs the localizer) and mapping (it extends a
:class:`~nightloc.ReferenceMap`); the map file's provenance records are :mod:`nightloc.io.appearances`.
"""

from __future__ import annotations

from .learning import LearningParams, LearningReport, LocalizedNight, NightLearner, learn, localize_night

__all__ = ["LearningParams", "LearningReport", "LocalizedNight", "NightLearner", "learn", "localize_night"]
