"""The motion types and the reference map keep the import paths users have: the old module paths
name the very objects of their stage modules, and the public names stay on the package."""

from __future__ import annotations

import importlib

import pytest

import nightloc
import nightloc.localization.odometry as localization_odometry
import nightloc.localization.wheel_noise as localization_wheel_noise
import nightloc.motion.odometry as motion_odometry
import nightloc.motion.wheel_noise as motion_wheel_noise


def test_localization_odometry_names_the_motion_stage_objects():
    assert set(localization_odometry.__all__) == set(motion_odometry.__all__) | {"Motion"}
    for name in localization_odometry.__all__:
        assert getattr(localization_odometry, name) is getattr(motion_odometry, name), name
    assert localization_wheel_noise.WheelNoise is motion_wheel_noise.WheelNoise


def test_package_names_are_the_stage_objects():
    assert nightloc.RobotMotion is motion_odometry.RobotMotion
    assert nightloc.NoiseModel is motion_odometry.NoiseModel
    assert nightloc.MapDisplacement is motion_odometry.MapDisplacement
    assert nightloc.traverse_odometry is motion_odometry.traverse_odometry
    assert nightloc.localization.RobotMotion is motion_odometry.RobotMotion
    assert nightloc.ReferenceMap is importlib.import_module("nightloc.mapping.reference_map").ReferenceMap


def test_io_no_longer_holds_the_reference_map_class():
    """io is a leaf: it reads and writes the map file; the class is the mapping stage's."""
    map_file = importlib.import_module("nightloc.io.map_file")
    assert not hasattr(map_file, "ReferenceMap")
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("nightloc.io.reference_map")
