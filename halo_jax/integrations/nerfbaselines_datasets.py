"""Our few-shot protocols as nerfbaselines datasets.

  blender-dietnerf/<scene>-n8   NeRF synthetic with the 8 training views of
                                DietNeRF's split that HALO's paper uses
                                (configs/blender.py: EIGHT_VIEWS); all 200
                                test views held out.
  llff-regnerf/<scene>-n{3,6,9} LLFF with RegNeRF's split (llff.py:<scene>_3view
                                ...): every 8th image held out, the training
                                views spread over the rest; images_8.

Both are scored by nerfbaselines' 'nerf' protocol. A scene is made from the
full one: `$HALO_DATA/nerf_synthetic/<scene>` (or `nerf_llff_data/<scene>`)
when it is there, else nerfbaselines' own copy, which it downloads. Images
are linked, not copied. Loaded in nerfbaselines' process: imports no jax.
"""
import ast
import importlib
import json
import os

import numpy as np

DATASET = "blender-dietnerf"
SUFFIX = "-n8"
LLFF = "llff-regnerf"
LLFF_VIEWS = (3, 6, 9)
LLFF_HOLD = 8       # RegNeRF holds out every 8th image
LLFF_FACTOR = 8     # ... and trains on images_8 (504x378 for LLFF)


def eight_views() -> dict:
  """{scene: [view names]} of configs/blender.py's EIGHT_VIEWS, read as data
  (the config module itself imports jax)."""
  from halo_jax import config_files  # pylint: disable=g-import-not-at-top
  path = config_files.resolve("configs/blender.py").partition(":")[0]
  if not os.path.exists(path):
    path = os.path.join(os.path.dirname(__file__), "..", "..", "configs", "blender.py")
  with open(path) as f:
    tree = ast.parse(f.read())
  for node in tree.body:
    if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", "") == "EIGHT_VIEWS":
      return {k: v.split() for k, v in ast.literal_eval(node.value).items()}
  raise RuntimeError(f"{path}: no EIGHT_VIEWS")


def _full_scene(folder: str, scene: str, marker: str, nb_name: str) -> str:
  """A full scene: $HALO_DATA/<folder>/<scene> when it holds `marker`, else
  nerfbaselines' copy of <nb_name>/<scene> (downloaded by nerfbaselines)."""
  local = os.path.join(os.environ.get("HALO_DATA", "data"), folder, scene)
  if os.path.exists(os.path.join(local, marker)):
    return local
  from nerfbaselines import NB_PREFIX  # pylint: disable=g-import-not-at-top
  target = os.path.join(NB_PREFIX, "datasets", nb_name, scene)
  if not os.path.exists(os.path.join(target, marker)):
    module = importlib.import_module(f"nerfbaselines.datasets.{nb_name}")
    getattr(module, f"download_{nb_name}_dataset")(f"{nb_name}/{scene}", target)
  return target


def _with_size(meta, folder):
  """Blender transforms with the image size nerfbaselines reads ("w", "h";
  it assumes 800x800 where they are absent, as in the original release)."""
  if "w" not in meta and meta["frames"]:
    from PIL import Image  # pylint: disable=g-import-not-at-top
    with Image.open(os.path.join(folder, meta["frames"][0]["file_path"] + ".png")) as im:
      meta = {**meta, "w": im.size[0], "h": im.size[1]}
  return meta


def write_few_shot(source: str, output: str, views, scene: str) -> None:
  """A Blender-layout scene in `output` whose training split is `views`
  (frame names such as 'r_2'), the test split all of source's."""
  os.makedirs(output, exist_ok=True)
  metas = {}
  for split in ("train", "test"):
    with open(os.path.join(source, f"transforms_{split}.json")) as f:
      metas[split] = _with_size(json.load(f), source)
  frames = {os.path.basename(fr["file_path"]): fr for fr in metas["train"]["frames"]}
  missing = [v for v in views if v not in frames]
  if missing:
    raise RuntimeError(f"{source}/transforms_train.json has no frames {missing}")
  metas["train"]["frames"] = [frames[v] for v in views]
  for split, meta in metas.items():
    with open(os.path.join(output, f"transforms_{split}.json"), "w") as f:
      json.dump(meta, f, indent=1)
  for name in ("train", "test"):
    if not os.path.exists(os.path.join(output, name)):
      os.symlink(os.path.abspath(os.path.join(source, name)), os.path.join(output, name))
  info = {"loader": "nerfbaselines.datasets.blender:load_blender_dataset", "id": DATASET,
          "scene": scene + SUFFIX, "evaluation_protocol": "nerf", "type": "object-centric"}
  with open(os.path.join(output, "nb-info.json"), "w") as f:
    json.dump(info, f, indent=1)


def download_blender_dietnerf(path: str, output: str) -> None:
  """nerfbaselines' download function for 'blender-dietnerf[/<scene>-n8]'."""
  from nerfbaselines import DatasetNotFoundError  # pylint: disable=g-import-not-at-top
  views = eight_views()
  if path == DATASET:
    for scene in views:
      download_blender_dietnerf(f"{DATASET}/{scene}{SUFFIX}", os.path.join(output,
                                                                           scene + SUFFIX))
    return
  name = path[len(DATASET) + 1:] if path.startswith(DATASET + "/") else ""
  scene = name[:-len(SUFFIX)] if name.endswith(SUFFIX) else ""
  if scene not in views:
    raise DatasetNotFoundError(f"{path}: use {DATASET}/<scene>{SUFFIX} with a scene of "
                               f"{sorted(views)}")
  write_few_shot(_full_scene("nerf_synthetic", scene, "transforms_train.json", "blender"),
                 output, views[scene], scene)


def regnerf_split(num_images: int, num_views: int):
  """(train, test) indices of RegNeRF's LLFF split, the rule of
  halo_jax.datasets.base.spread_views (a test checks they agree)."""
  test = list(range(0, num_images, LLFF_HOLD))
  rest = [i for i in range(num_images) if i % LLFF_HOLD]
  return [rest[round(float(x))] for x in np.linspace(0, len(rest) - 1, num_views)], test


def load_llff_regnerf(path: str, split: str, num_views: int = 3, **kwargs):
  """nerfbaselines' loader of an LLFF scene at factor 8 with RegNeRF's split
  (nerfbaselines' own llff loader reads images_4 and holds out every 8th
  image, training on all the rest)."""
  del kwargs
  from nerfbaselines import camera_model_to_int, new_cameras, new_dataset  # pylint: disable=g-import-not-at-top
  poses_bounds = np.load(os.path.join(path, "poses_bounds.npy"))
  folder = os.path.join(path, f"images_{LLFF_FACTOR}")
  files = sorted(f for f in os.listdir(folder) if f.lower().endswith((".png", ".jpg")))
  if len(files) != len(poses_bounds):
    raise RuntimeError(f"{folder}: {len(files)} images for {len(poses_bounds)} poses")
  from PIL import Image  # pylint: disable=g-import-not-at-top
  with Image.open(os.path.join(folder, files[0])) as im:
    w, h = im.size
  poses = poses_bounds[:, :15].reshape(-1, 3, 5)
  focal = poses[0, 2, 4] * w / poses[0, 1, 4]
  # LLFF's "down right back" axes -> OpenGL's "right up back" -> OpenCV's
  c2w = np.concatenate([poses[..., 1:2], -poses[..., :1], poses[..., 2:4]], -1)
  c2w[..., 1:3] *= -1
  train, test = regnerf_split(len(files), num_views)
  idx = np.array(train if split == "train" else test)
  k = len(idx)
  return new_dataset(
      cameras=new_cameras(
          poses=c2w[idx].astype(np.float32),
          intrinsics=np.tile(np.array([focal, focal, w / 2, h / 2], np.float32), (k, 1)),
          camera_models=np.full(k, camera_model_to_int("pinhole"), np.int32),
          distortion_parameters=np.zeros((k, 0), np.float32),
          image_sizes=np.tile(np.array([w, h], np.int32), (k, 1)),
          nears_fars=poses_bounds[idx, -2:].astype(np.float32)),
      image_paths_root=path, image_paths=[os.path.join(folder, files[i]) for i in idx],
      metadata={"color_space": "srgb", "type": "forward-facing",
                "evaluation_protocol": "nerf", "downscale_factor": LLFF_FACTOR})


def download_llff_regnerf(path: str, output: str) -> None:
  """nerfbaselines' download function for 'llff-regnerf/<scene>-n<k>'."""
  from nerfbaselines import DatasetNotFoundError  # pylint: disable=g-import-not-at-top
  name = path[len(LLFF) + 1:] if path.startswith(LLFF + "/") else ""
  scene, _, views = name.rpartition("-n")
  if not scene or not views.isdigit() or int(views) not in LLFF_VIEWS:
    raise DatasetNotFoundError(f"{path}: use {LLFF}/<scene>-n3, -n6 or -n9")
  source = _full_scene("nerf_llff_data", scene, "poses_bounds.npy", "llff")
  os.makedirs(output, exist_ok=True)
  for entry in ("poses_bounds.npy", f"images_{LLFF_FACTOR}"):
    if not os.path.exists(os.path.join(output, entry)):
      os.symlink(os.path.abspath(os.path.join(source, entry)), os.path.join(output, entry))
  info = {"loader": f"{__name__}:load_llff_regnerf", "loader_kwargs": {"num_views": int(views)},
          "id": LLFF, "scene": name, "evaluation_protocol": "nerf", "type": "forward-facing"}
  with open(os.path.join(output, "nb-info.json"), "w") as f:
    json.dump(info, f, indent=1)


def register_all(register) -> None:
  """Registers the datasets with nerfbaselines' `register`."""
  register({
      "id": DATASET,
      "download_dataset_function": f"{__name__}:download_blender_dietnerf",
      "evaluation_protocol": "nerf",
      "metadata": {
          "id": DATASET, "name": "Blender, 8 views (DietNeRF's split)",
          "description": "NeRF synthetic with the 8 training views HALO and DietNeRF train "
                         "on; every test view held out.",
          "paper_title": "Putting NeRF on a Diet: Semantically Consistent Few-Shot View "
                         "Synthesis",
          "paper_authors": ["Ajay Jain", "Matthew Tancik", "Pieter Abbeel"],
          "metrics": ["psnr", "ssim", "lpips"], "default_metric": "psnr",
          "scenes": [{"id": s + SUFFIX, "name": f"{s} (8 views)"} for s in eight_views()],
      },
  })
  llff_scenes = "fern flower fortress horns leaves orchids room trex".split()
  register({
      "id": LLFF,
      "download_dataset_function": f"{__name__}:download_llff_regnerf",
      "evaluation_protocol": "nerf",
      "metadata": {
          "id": LLFF, "name": "LLFF, 3 / 6 / 9 views (RegNeRF's split)",
          "description": "LLFF at 504x378 with every 8th image held out and 3, 6 or 9 "
                         "training views spread over the rest.",
          "paper_title": "RegNeRF: Regularizing Neural Radiance Fields for View Synthesis "
                         "from Sparse Inputs",
          "paper_authors": ["Michael Niemeyer", "Jonathan T. Barron", "Ben Mildenhall",
                            "Mehdi S. M. Sajjadi", "Andreas Geiger", "Noha Radwan"],
          "metrics": ["psnr", "ssim", "lpips"], "default_metric": "psnr",
          "scenes": [{"id": f"{s}-n{k}", "name": f"{s} ({k} views)"} for s in llff_scenes
                     for k in LLFF_VIEWS],
      },
  })
