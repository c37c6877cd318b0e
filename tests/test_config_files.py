"""--config paths resolve to the configs shipped in the package from any directory."""
import os

from halo_jax import config_files, configure


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
  c = configure.load("procedural.py:lattice_8view_cpu", "freenerf")
  assert c.method == "freenerf" and c.data.procedural_scene == "lattice"


def test_the_command_line_sets_its_overrides_after_the_method():
  """--config names the scene, --method the method; --config.* overrides are
  set after the method, so they win over what it sets (nerf_paper's 1024 rays
  a batch here), and fields the command line leaves alone are the method's.
  The file is read by configure.load_scene, the loader of every entry point."""
  from absl import flags  # pylint: disable=g-import-not-at-top
  from ml_collections import config_flags  # pylint: disable=g-import-not-at-top
  from halo_jax import cli  # pylint: disable=g-import-not-at-top
  argv = config_files.resolve_argv(["prog", "--config=blender.py:lego_8view_cpu",
                                    "--config.hi.batch_rays=64", "--config.seed=3"])
  fv = flags.FlagValues()
  config_flags.DEFINE_config_file("config", None, "scene", flag_values=fv, sys_argv=argv)
  fv(argv)
  c = cli.config_of_flags(fv["config"], "nerf_paper")
  assert (c.method, c.hi.batch_rays, c.seed, c.hi.sampler.kind) == ("nerf_paper", 64, 3,
                                                                     "coarse_fine")
  assert configure.load("blender.py:lego_8view_cpu", "nerf_paper").hi.batch_rays == 1024
  assert cli.config_of_flags(fv["config"], "halo").stages == "lo,ray,hi"
  assert fv["config"].value.method == ""   # the flag's own scene is left as it was
