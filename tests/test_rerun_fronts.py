"""experiments/rerun_fronts.py: which scenes are already on the current code."""
import json
import os

from experiments import rerun_fronts

OLD = "0123456789abcdef0123456789abcdef01234567"   # not in this repository:
NEW = "fedcba9876543210fedcba9876543210fedcba98"   # each names its own version


def _write(root, scene, method, seed, commit, front=True):
  path = os.path.join(root, rerun_fronts.SUITE_DIR, scene, method, f"seed{seed}.json")
  os.makedirs(os.path.dirname(path), exist_ok=True)
  rec = {"provenance": {"git": {"commit": commit, "dirty": False}},
         "front": [{"at_s": 15.0, "psnr": 10.0}] if front else []}
  with open(path, "w") as f:
    json.dump(rec, f)


def test_a_scene_is_up_to_date_only_when_every_pair_record_has_a_front_of_this_code(tmp_path):
  root, methods, seeds = str(tmp_path), ["nerf_tuned", "halo"], ["0", "1"]
  for m in methods:
    for s in seeds:
      _write(root, "a", m, s, NEW)
  assert rerun_fronts.up_to_date(root, "a", methods, seeds, "fedcba9")
  assert not rerun_fronts.up_to_date(root, "a", methods, seeds, "0123456")  # other code
  _write(root, "a", "halo", "1", OLD)                                       # one record older
  assert not rerun_fronts.up_to_date(root, "a", methods, seeds, "fedcba9")
  _write(root, "a", "halo", "1", NEW, front=False)                          # one without a front
  assert not rerun_fronts.up_to_date(root, "a", methods, seeds, "fedcba9")
  assert not rerun_fronts.up_to_date(root, "b", methods, seeds, "fedcba9")  # nothing at all
