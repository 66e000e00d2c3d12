"""nightloc.studies: experiments a user can rerun, built from the pipeline's own stages.

* :mod:`~nightloc.studies.camera` — which camera a robot needs: matching resolution x night
  darkness x sensor pixel -> localization error (``nightloc camera-study``).
"""

from __future__ import annotations

from .camera import (
    CSV_HEADER,
    DEFAULT_DARKNESS_LEVELS,
    DEFAULT_SENSORS,
    DEFAULT_SIZES,
    CameraStudy,
    Sensor,
    StudyRow,
    StudySettings,
    run_camera_study,
)

__all__ = [
    "CSV_HEADER",
    "DEFAULT_DARKNESS_LEVELS",
    "DEFAULT_SENSORS",
    "DEFAULT_SIZES",
    "CameraStudy",
    "Sensor",
    "StudyRow",
    "StudySettings",
    "run_camera_study",
]
