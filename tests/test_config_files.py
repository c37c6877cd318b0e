"""--config paths resolve to the configs shipped in the package from any directory."""
import os

from halo_jax import config_files, runs


def test_shipped_configs_resolve_from_anywhere(tmp_path, monkeypatch):
  monkeypatch.chdir(tmp_path)
  folder = config_files.shipped_folder()
  assert os.path.exists(os.path.join(folder, "blender.py"))
  for spec in ("blender.py:lego_8view", "configs/blender.py:lego_8view"):
    path, _, variant = config_files.resolve(spec).partition(":")
    assert os.path.samefile(path, os.path.join(folder, "blender.py")) and variant == "lego_8view"
  assert config_files.resolve("nope.py:x") == "nope.py:x"  # the loader names it
  argv = config_files.resolve_argv(["prog", "--config=dnerf.py:hook_cpu", "--config", "llff.py"])
  assert argv[1].endswith(os.path.join("", "dnerf.py:hook_cpu")) and os.path.isabs(argv[1][9:])
  assert os.path.isabs(argv[3])
  c = runs.load_config("procedural.py:lattice_8view_cpu_freenerf")
  assert c.method == "freenerf" and c.data.procedural_scene == "lattice"
