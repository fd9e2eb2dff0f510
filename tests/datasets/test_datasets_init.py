"""Tests of the hopmatch.datasets package: every name of its modules that it promises is
importable from it, and is the same object."""

from __future__ import annotations

import hopmatch.datasets as ds
from hopmatch.datasets import calibration, catalogue, readers


def test_all_names_are_the_modules_objects():
    for name in ds.__all__:
        obj = getattr(ds, name)
        homes = [m for m in (calibration, catalogue, readers)
                 if name in getattr(m, "__all__", ())]
        assert len(homes) == 1, name
        assert getattr(homes[0], name) is obj, name


def test_public_names_of_the_former_module():
    former = {"StereoScene", "list_scenes", "load", "load_motorcycle", "load_scene",
              "read_kitti_calib", "read_kitti_disparity", "read_middlebury_calib",
              "read_middlebury_disparity", "read_pfm", "shared_data_dir"}
    assert former <= set(ds.__all__)
    assert ds.SHARED_DATA_ENV == "HOPMATCH_SHARED_DATA" and ds.MOTORCYCLE == "motorcycle"
    assert set(ds.__all__) == former | {"MOTORCYCLE", "SHARED_DATA_ENV"}
