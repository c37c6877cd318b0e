"""Bad input is refused before any training, with the file and field named."""
import json
import os
import shutil

import imageio.v3 as iio
import numpy as np
import pytest

from halo_jax import datasets, pipeline
from halo_jax.registry import ConfigError
from conftest import tiny_config
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top


def _scene(scene_root, tmp_path):
  root = str(tmp_path / "scene")
  shutil.copytree(scene_root, root)
  return root


def _edit_json(root, edit):
  path = os.path.join(root, "transforms_train.json")
  with open(path) as f:
    meta = json.load(f)
  edit(meta)
  with open(path, "w") as f:
    json.dump(meta, f)


def _frame(meta, name):
  return next(fr for fr in meta["frames"] if fr["file_path"].endswith(name))


def _garbage_image(root):
  with open(os.path.join(root, "train", "r_13.png"), "wb") as f:
    f.write(b"\x89PNG\r\n\x1a\n not really a png")


def _small_image(root):
  iio.imwrite(os.path.join(root, "train", "r_13.png"), np.zeros((32, 32, 4), np.uint8))


def _scale_rotation(meta):
  m = np.asarray(_frame(meta, "r_13")["transform_matrix"])
  m[:3, :3] *= 1.5
  _frame(meta, "r_13")["transform_matrix"] = m.tolist()


def _reflect(meta):
  m = np.asarray(_frame(meta, "r_13")["transform_matrix"])
  m[:3, 0] *= -1
  _frame(meta, "r_13")["transform_matrix"] = m.tolist()


def _set_entry(name, row, col, value):
  def edit(meta):
    _frame(meta, name)["transform_matrix"][row][col] = value
  return edit


CASES = {
    "missing image": (lambda r: os.remove(os.path.join(r, "train", "r_13.png")),
                      r"train/r_13\.png: image file not found"),
    "unreadable image": (_garbage_image, r"train/r_13\.png: cannot read image"),
    "image of another size": (_small_image,
                              r"train/r_13\.png: size 32x32 differs from 64x64 of the other views"),
    "malformed json": (lambda r: open(os.path.join(r, "transforms_train.json"), "w").write("{ oops"),
                       r"transforms_train\.json: malformed JSON"),
    "json not an object": (lambda r: open(os.path.join(r, "transforms_train.json"), "w").write("[]"),
                           r"transforms_train\.json: expected a JSON object"),
    "no camera_angle_x": (lambda r: _edit_json(r, lambda m: m.pop("camera_angle_x")),
                          r"transforms_train\.json: missing field 'camera_angle_x'"),
    "camera_angle_x not a number": (
        lambda r: _edit_json(r, lambda m: m.update(camera_angle_x="wide")),
        r"transforms_train\.json: field 'camera_angle_x' must be a number"),
    "no frames": (lambda r: _edit_json(r, lambda m: m.update(frames=[])),
                  r"transforms_train\.json: missing or empty field 'frames'"),
    "frame without pose": (lambda r: _edit_json(r, lambda m: m["frames"][2].pop("transform_matrix")),
                           r"transforms_train\.json: frames\[2\] has no field 'transform_matrix'"),
    "NaN pose": (lambda r: _edit_json(r, _set_entry("r_13", 1, 3, float("nan"))),
                 r"transforms_train\.json: 'transform_matrix' of r_13 is not a finite 4x4"),
    "infinite pose": (lambda r: _edit_json(r, _set_entry("r_13", 0, 0, float("inf"))),
                      r"transforms_train\.json: 'transform_matrix' of r_13 is not a finite 4x4"),
    "pose not 4x4": (lambda r: _edit_json(r, lambda m: _frame(m, "r_13").update(
        transform_matrix=_frame(m, "r_13")["transform_matrix"][:3])),
                     r"transforms_train\.json: 'transform_matrix' of r_13 is not a finite 4x4"),
    "pose with text": (lambda r: _edit_json(r, _set_entry("r_13", 0, 1, "x")),
                       r"transforms_train\.json: 'transform_matrix' of r_13 is not a finite 4x4"),
    "pose not rigid": (lambda r: _edit_json(r, _scale_rotation),
                       r"transforms_train\.json: 'transform_matrix' of r_13 is not rigid"),
    "pose a reflection": (lambda r: _edit_json(r, _reflect),
                          r"transforms_train\.json: 'transform_matrix' of r_13 is not rigid "
                          r"\(a reflection"),
    "pose last row": (lambda r: _edit_json(r, _set_entry("r_13", 3, 0, 0.5)),
                      r"transforms_train\.json: 'transform_matrix' of r_13 has last row"),
    "view not in data": (lambda r: _edit_json(r, lambda m: m["frames"].remove(_frame(m, "r_13"))),
                         r"transforms_train\.json: views \['r_13'\] named in the config are not "
                         r"in 'frames'"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_bad_input_is_refused_before_training(case, scene_root, tmp_path):
  breaks, message = CASES[case]
  root = _scene(scene_root, tmp_path)
  breaks(root)
  c = tiny_config()
  c.data.kind = "blender"    # read the broken copy as it is, do not regenerate it
  c.data.root = root
  wd = str(tmp_path / "run")
  with pytest.raises(datasets.DataError, match=message):
    pipeline.run(finish(c), wd)
  assert not os.path.exists(os.path.join(wd, "lo")), "training started before the error"


def test_empty_data_root_and_unknown_kind():
  c = tiny_config()
  c.data.kind = "blender"
  c.data.root = ""
  with pytest.raises(datasets.DataError, match="data.root is empty"):
    datasets.load(c.data)
  c.data.kind = "colmap"
  with pytest.raises(ConfigError, match="data.kind='colmap' is not a known dataset"):
    datasets.load(c.data)
