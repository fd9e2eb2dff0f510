"""Tests of hopmatch.datasets.catalogue: scene folders described by a meta.json, the
catalogue and the shared data lookup, the built-in motorcycle scene, and the real scenes
of ../shared/data."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from dataset_files import (
    KITTI_CALIB,
    MIDDLEBURY_CALIB,
    grey,
    make_scene,
    photometric_error,
    write_pfm,
)

from hopmatch import datasets as ds
from hopmatch.datasets import (
    StereoScene,
    list_scenes,
    load,
    load_motorcycle,
    load_scene,
    read_kitti_disparity,
    shared_data_dir,
)
from hopmatch.errors import FileReadError, InvalidArgumentError, InvalidTypeError

ROOT = Path(__file__).resolve().parents[2]

# --------------------------------------------------------------------------------------
# meta.json scenes
# --------------------------------------------------------------------------------------


class TestLoadScene:
    def test_minimal(self, tmp_path):
        folder = make_scene(tmp_path / "tiny")
        s = load_scene(folder)
        assert isinstance(s, StereoScene)
        assert s.name == "tiny" and s.folder == folder
        assert s.left.shape == (6, 10, 3) and s.left.dtype == np.uint8
        np.testing.assert_array_equal(s.left, cv2.imread(str(folder / "left.png")))
        assert s.disparity.dtype == np.float32 and s.shape == (6, 10) and s.image_size == (10, 6)
        assert np.isnan(s.disparity[:, :2]).all() and (s.disparity[:, 2:] == 2).all()
        np.testing.assert_array_equal(s.valid, ~np.isnan(s.disparity))
        assert s.source == "nobody, 2024" and s.dataset == "tiny" and s.calibration is None
        assert s.disparity_right is None and s.nonoccluded_mask is None
        assert "tiny" in repr(s) and "2..2 px" in repr(s)
        # The ground truth is right: left (x, y) shows what right (x - d, y) shows.
        ys, xs = np.nonzero(s.valid)
        xr = (xs - s.disparity[ys, xs]).astype(int)
        np.testing.assert_array_equal(s.left[ys, xs], s.right[ys, xr])

    def test_optional_files(self, tmp_path):
        folder = make_scene(
            tmp_path / "full",
            disp_right="disp_right.pgm",
            nonoccluded_mask="mask.png",
            disp_all="disp_left.pgm",
        )
        (folder / "dmin.txt").write_text("200\n")
        s = load_scene(folder, name="custom")
        assert s.name == "custom"
        np.testing.assert_array_equal(s.disparity_right, s.disparity)
        np.testing.assert_array_equal(s.disparity_all, s.disparity)
        assert s.nonoccluded_mask.dtype == np.bool_
        np.testing.assert_array_equal(s.nonoccluded_mask, s.valid)
        assert s.meta["dmin"] == 200.0

    def test_grey_images_stay_grey(self, tmp_path):
        folder = make_scene(tmp_path / "g")
        cv2.imwrite(str(folder / "left.png"), np.zeros((6, 10), np.uint8))
        cv2.imwrite(str(folder / "right.png"), np.zeros((6, 10), np.uint8))
        assert load_scene(folder).left.shape == (6, 10)

    def test_kitti_calibration_with_description(self, tmp_path):
        folder = make_scene(tmp_path / "k", calibration="calib.txt (KITTI P0..P3; blah)")
        (folder / "calib.txt").write_text(KITTI_CALIB)
        c = load_scene(folder).calibration
        assert c["focal_length"] == pytest.approx(718.856) and c["P3"].shape == (3, 4)

    def test_middlebury_calibration(self, tmp_path):
        folder = make_scene(tmp_path / "m", calibration="calib.txt")
        (folder / "calib.txt").write_text(MIDDLEBURY_CALIB)
        assert load_scene(folder).calibration["doffs"] == pytest.approx(131.111)

    def test_calibration_dict(self, tmp_path):
        folder = make_scene(tmp_path / "d", calibration={"f": 100.0, "K": [[1, 0], [0, 1]]})
        c = load_scene(folder).calibration
        assert c["f"] == 100.0 and c["K"].shape == (2, 2)

    def test_unknown_calibration_format(self, tmp_path):
        folder = make_scene(tmp_path / "u", calibration="calib.txt")
        (folder / "calib.txt").write_text("focal 100\n")
        with pytest.raises(InvalidArgumentError, match="neither KITTI"):
            load_scene(folder)

    def test_pfm_disparity(self, tmp_path):
        folder = make_scene(tmp_path / "p", disp="disp0.pfm", scale=1, unknown_value=None)
        d = np.full((6, 10), 2.0, np.float32)
        d[:, :2] = np.inf
        d[0, 5] = 0.0  # a real zero: PFM scenes have no unknown_value by default
        write_pfm(folder / "disp0.pfm", d, "<")
        s = load_scene(folder)
        assert np.isnan(s.disparity[:, :2]).all() and s.disparity[0, 5] == 0.0

    def test_missing_meta(self, tmp_path):
        (tmp_path / "empty").mkdir()
        with pytest.raises(InvalidArgumentError, match="meta.json.*does not exist"):
            load_scene(tmp_path / "empty")

    def test_missing_folder(self, tmp_path):
        with pytest.raises(InvalidArgumentError, match="does not exist"):
            load_scene(tmp_path / "nowhere")

    def test_invalid_json(self, tmp_path):
        folder = make_scene(tmp_path / "j")
        (folder / "meta.json").write_text("{left: nope")
        with pytest.raises(InvalidArgumentError, match="not valid JSON") as exc:
            load_scene(folder)
        assert "meta.json" in str(exc.value)

    def test_not_an_object(self, tmp_path):
        folder = make_scene(tmp_path / "j")
        (folder / "meta.json").write_text("[1, 2]")
        with pytest.raises(InvalidArgumentError, match="JSON object"):
            load_scene(folder)

    def test_missing_key(self, tmp_path):
        folder = make_scene(tmp_path / "k", scale=None)
        with pytest.raises(InvalidArgumentError, match=r"lacks the key\(s\) \['scale'\]"):
            load_scene(folder)

    def test_bad_scale(self, tmp_path):
        folder = make_scene(tmp_path / "k", scale=0)
        with pytest.raises(InvalidArgumentError, match="meta.json.*scale"):
            load_scene(folder)

    @pytest.mark.parametrize("value", ["zero", True])
    def test_bad_unknown_value(self, tmp_path, value):
        folder = make_scene(tmp_path / "k", unknown_value=value)
        with pytest.raises(InvalidArgumentError,
                           match="meta.json.*`unknown_value` must be a number"):
            load_scene(folder)

    def test_bad_file_name(self, tmp_path):
        folder = make_scene(tmp_path / "k", left=3)
        with pytest.raises(InvalidArgumentError, match="`left` must be a file name"):
            load_scene(folder)

    def test_missing_image(self, tmp_path):
        folder = make_scene(tmp_path / "k")
        (folder / "right.png").unlink()
        with pytest.raises(FileReadError,
                           match="right.png: the right image file does not exist") as exc:
            load_scene(folder)
        assert exc.value.kind == "missing" and exc.value.path.endswith("right.png")

    def test_size_mismatch(self, tmp_path):
        folder = make_scene(tmp_path / "k")
        cv2.imwrite(str(folder / "disp_left.pgm"), np.zeros((5, 10), np.uint8))
        with pytest.raises(InvalidArgumentError, match=r"disparity has size \(5, 10\).*\(6, 10\)"):
            load_scene(folder)

    def test_bad_dmin(self, tmp_path):
        folder = make_scene(tmp_path / "k")
        (folder / "dmin.txt").write_text("many\n")
        with pytest.raises(InvalidArgumentError, match="dmin.txt"):
            load_scene(folder)


class TestCatalogue:
    def test_shared_data_dir_env(self, tmp_path, monkeypatch):
        monkeypatch.setenv(ds.SHARED_DATA_ENV, str(tmp_path))
        assert shared_data_dir() == tmp_path

    def test_shared_data_dir_absent(self, tmp_path, monkeypatch):
        monkeypatch.setenv(ds.SHARED_DATA_ENV, str(tmp_path / "absent"))
        assert shared_data_dir(must_exist=False) is None
        with pytest.raises(InvalidArgumentError, match="HOPMATCH_SHARED_DATA") as exc:
            shared_data_dir()
        assert "absent" in str(exc.value)
        # Without shared data only the built-in scene is listed, and loading says why.
        assert list_scenes() == ["motorcycle"]
        with pytest.raises(InvalidArgumentError, match="shared stereo data folder is absent"):
            load("middlebury/tsukuba")

    def test_shared_data_dir_where_a_user_keeps_it(self, tmp_path, monkeypatch):
        """Without the variable: shared/data in the working directory, then ../shared/data,
        then beside the source checkout (issue 19, point 7)."""
        monkeypatch.delenv(ds.SHARED_DATA_ENV, raising=False)
        here, beside = tmp_path / "work" / "shared" / "data", tmp_path / "shared" / "data"
        here.mkdir(parents=True)
        beside.mkdir(parents=True)
        monkeypatch.chdir(tmp_path / "work")
        assert shared_data_dir() == here
        here.rmdir()
        assert shared_data_dir() == beside
        beside.rmdir()
        checkout = ROOT.parent / "shared" / "data"
        if checkout.is_dir():  # running from a clone with the data beside it
            assert shared_data_dir() == checkout
        else:
            with pytest.raises(InvalidArgumentError, match="shared stereo data") as exc:
                shared_data_dir()
            assert repr(str(checkout)) in str(exc.value)

    def test_variable_wins_over_nearby_folders(self, tmp_path, monkeypatch):
        (tmp_path / "shared" / "data").mkdir(parents=True)
        (tmp_path / "elsewhere").mkdir()
        monkeypatch.chdir(tmp_path)
        monkeypatch.setenv(ds.SHARED_DATA_ENV, str(tmp_path / "elsewhere"))
        assert shared_data_dir() == tmp_path / "elsewhere"

    def test_installed_package_never_looks_in_its_environment(self, tmp_path, monkeypatch):
        """An installed hopmatch (no pyproject.toml beside the package) looks where the
        user works, not under ``.venv/lib/python3.X``; the message says where it looked."""
        from hopmatch.datasets import catalogue

        site = tmp_path / ".venv" / "lib" / "python3.11" / "site-packages"
        (site / "hopmatch").mkdir(parents=True)
        (site.parent / "shared" / "data").mkdir(parents=True)  # what the old lookup found
        monkeypatch.setattr(catalogue, "_PROJECT_ROOT", site)
        monkeypatch.delenv(ds.SHARED_DATA_ENV, raising=False)
        (tmp_path / "project" / "shared" / "data").mkdir(parents=True)
        monkeypatch.chdir(tmp_path / "project")
        assert shared_data_dir() == tmp_path / "project" / "shared" / "data"
        monkeypatch.chdir(tmp_path / ".venv")
        with pytest.raises(InvalidArgumentError, match="shared stereo data folder is absent") \
                as exc:
            shared_data_dir()
        message = str(exc.value)
        assert "python3.11" not in message
        for place in (tmp_path / ".venv" / "shared" / "data", tmp_path / "shared" / "data"):
            assert repr(str(place)) in message
        assert "./shared/data" in message and "../shared/data" in message
        assert "HOPMATCH_SHARED_DATA" in message

    def test_list_and_load_from_root(self, tmp_path):
        make_scene(tmp_path / "set" / "a")
        make_scene(tmp_path / "b")
        (tmp_path / "no_meta").mkdir()
        assert list_scenes(tmp_path) == ["motorcycle", "b", "set/a"]
        s = load("set/a", root=tmp_path)
        assert s.name == "set/a" and s.shape == (6, 10)

    def test_name_relative_to_shared_data(self, tmp_path, monkeypatch):
        make_scene(tmp_path / "set" / "a")
        monkeypatch.setenv(ds.SHARED_DATA_ENV, str(tmp_path))
        assert load_scene(tmp_path / "set" / "a").name == "set/a"
        assert load("set/a").name == "set/a"

    def test_unknown_name_lists_available(self, tmp_path):
        make_scene(tmp_path / "b")
        with pytest.raises(InvalidArgumentError, match="unknown scene 'zzz'.*motorcycle, b"):
            load("zzz", root=tmp_path)
        with pytest.raises(InvalidArgumentError, match="unknown scene"):
            load("../b", root=tmp_path / "b")

    def test_bad_root(self, tmp_path):
        with pytest.raises(InvalidArgumentError, match="not a folder"):
            list_scenes(tmp_path / "absent")

    def test_name_type(self):
        with pytest.raises(InvalidTypeError, match="`name`"):
            load(3)


# --------------------------------------------------------------------------------------
# The built-in motorcycle scene
# --------------------------------------------------------------------------------------


class TestMotorcycle:
    def test_arrays(self, motorcycle):
        left_rgb, right_rgb, disp = motorcycle
        s = load_motorcycle()
        assert s.name == "motorcycle" and load("motorcycle").name == "motorcycle"
        # BGR, like cv2.imread; scikit-image gives RGB.
        np.testing.assert_array_equal(s.left, left_rgb[..., ::-1])
        np.testing.assert_array_equal(s.right, right_rgb[..., ::-1])
        assert s.disparity.dtype == np.float32 and s.shape == (500, 741)
        np.testing.assert_array_equal(np.isnan(s.disparity), ~np.isfinite(disp))
        assert np.isinf(disp).any()  # the source uses inf, which became NaN
        known = s.disparity[s.valid]
        assert 5 < known.min() and known.max() < 70

    def test_calibration(self):
        c = load_motorcycle().calibration
        assert c["focal_length"] == 994.978 and c["baseline"] == 193.001
        assert c["doffs"] == 31.086 and c["cx"] == 311.193 and c["cy"] == 254.877
        assert c["cam1"][0, 2] - c["cam0"][0, 2] == pytest.approx(c["doffs"])
        assert (c["width"], c["height"]) == (741.0, 500.0)

    def test_sign_convention(self):
        """Warping right to left with xr = xl - d beats xr = xl + d by far."""
        s = load_motorcycle()
        minus, plus = photometric_error(s, -1), photometric_error(s, +1)
        assert minus < 12 and minus < plus / 3


# --------------------------------------------------------------------------------------
# The real scenes of ../shared/data
# --------------------------------------------------------------------------------------

EXPECTED = {
    "aloe",
    "kitti2012/000070",
    "middlebury/tsukuba",
    "middlebury/venus",
    "middlebury/sawtooth",
    "middlebury/bull",
    "middlebury/poster",
    "middlebury/barn1",
    "middlebury/barn2",
    "middlebury/art",
    "middlebury/books",
    "middlebury/dolls",
}


@pytest.mark.shared_data
class TestSharedData:
    def test_list(self, shared_data):
        names = list_scenes(shared_data)
        assert names[0] == "motorcycle" and EXPECTED <= set(names)

    def test_tsukuba_end_to_end(self, shared_data):
        s = load("middlebury/tsukuba", root=shared_data)
        assert s.shape == (288, 384) and s.left.shape == (288, 384, 3)
        assert "Scharstein" in s.source
        known = s.disparity[s.valid]
        assert 0.5 < s.valid.mean() < 1
        assert 0 <= known.min() and known.max() <= 16.5  # Tsukuba: 5..14 px
        assert s.nonoccluded_mask is not None and s.nonoccluded_mask.shape == s.shape
        # Shifting left pixels by the ground truth lands on similar intensities.
        lg, rg = grey(s.left).astype(np.float32), grey(s.right).astype(np.float32)
        ys, xs = np.nonzero(s.valid & s.nonoccluded_mask)
        xr = np.rint(xs - s.disparity[ys, xs]).astype(int)
        inside = (xr >= 0) & (xr < s.shape[1])
        ys, xs, xr = ys[inside], xs[inside], xr[inside]
        diff_gt = np.abs(lg[ys, xs] - rg[ys, xr]).mean()
        diff_none = np.abs(lg[ys, xs] - rg[ys, xs]).mean()
        assert diff_gt < 8 and diff_gt < diff_none / 3

    def test_kitti(self, shared_data):
        s = load("kitti2012/000070", root=shared_data)
        assert s.left.ndim == 2 and s.shape == (376, 1241)
        assert s.calibration["focal_length"] == pytest.approx(718.856)
        assert s.calibration["baseline"] == pytest.approx(0.537, abs=1e-3)
        # Sparse LiDAR ground truth; disp_occ knows at least what disp_noc knows.
        assert 0.1 < s.valid.mean() < 0.6
        assert s.disparity_all is not None
        assert (np.isfinite(s.disparity_all) >= s.valid).all()
        # Where both know, they agree, but not bit for bit: about 0.2 % of the pixels
        # differ by up to 0.4 px in the files as shipped.
        diff = np.abs(s.disparity_all[s.valid] - s.disparity[s.valid])
        assert (diff == 0).mean() > 0.99 and diff.max() < 0.5
        np.testing.assert_array_equal(s.disparity, read_kitti_disparity(s.folder / "disp_noc.png"))

    def test_middlebury_2005_dmin_and_right_disparity(self, shared_data):
        s = load("middlebury/art", root=shared_data)
        assert s.meta["dmin"] == 200.0 and s.disparity_right is not None
        assert np.nanmax(s.disparity) <= 255 / 2

    @pytest.mark.parametrize("name", sorted(EXPECTED))
    def test_every_scene_sign_and_scale(self, shared_data, name):
        """xr = xl - d / scale matches; the opposite sign, or a doubled scale, does not."""
        s = load(name, root=shared_data)
        good = photometric_error(s, -1)
        assert good < photometric_error(s, +1) / 2
        half = StereoScene(s.name, s.left, s.right, s.disparity / 2, None, "")
        assert good < photometric_error(half, -1)
