"""Sweeps any config fields from the command line; one workdir per point.

  halo-sweep --config=configs/blender.py:lego_8view_cpu --workdir=DIR [--method=halo] \
      --sweep=lo.encoding.L=3,5,7 --sweep=lo.encoding.scale=1,8,32 [--config.stages=lo]
  halo-sweep ... --sweep='data.train_views=["r_2,r_16", "r_2,r_16,r_93"]'   # values with commas

Runs `config.stages` for every point of the product of the --sweep lists (in
DIR/<field=value,...>; a killed sweep resumes, finished points are restored),
then writes DIR/results.json, DIR/results.md and DIR/sweep.png: for each point
the held-out PSNR / SSIM / LPIPS of the last stage run, its training seconds
and, when the point trained a Lo-NeRF, the frequency criterion of that Lo-NeRF
(halo_jax/frequency/tuning.py, settings from config.tune).
"""
import itertools
import json
import os

from absl import flags

from halo_jax import datasets, pipeline, plots, progress, stages, tables
from halo_jax.frequency import tuning
from halo_jax.cli import run_app, config_of_flags, define_config_flag, define_method_flag, launch
from halo_jax.stages import radiance

FLAGS = flags.FLAGS


def define_flags():
  """The command's flags, defined on launch (the tests import this module)."""
  define_config_flag("Base config (path[:variant]).")
  flags.DEFINE_string("workdir", None, "Output folder.")
  define_method_flag()
  flags.DEFINE_multi_string("sweep", [], "field=v1,v2,... (repeat for a product).")
  flags.DEFINE_bool("criterion", True, "Score each point's Lo-NeRF with the frequency criterion.")
  flags.mark_flags_as_required(["config", "workdir"])


def _convert(config, field, text):
  """Parses `text` as the type of config field `field` (dotted)."""
  *parents, leaf = field.split(".")
  node = config
  for p in parents:
    node = node[p]
  if leaf not in node:
    raise ValueError(f"--sweep: config has no field {field!r}")
  current = node[leaf]
  if isinstance(current, bool):
    if text.lower() not in ("true", "false", "1", "0"):
      raise ValueError(f"--sweep: {field} is a bool, got {text!r}")
    return text.lower() in ("true", "1")
  if isinstance(current, (int, float)):
    return type(current)(float(text)) if isinstance(current, int) else float(text)
  return text


def parse_sweeps(config, specs):
  """['a.b=1,2', 'c=x,y'] -> list of points, each [(field, value), ...]."""
  axes = []
  for spec in specs:
    if "=" not in spec:
      raise ValueError(f"--sweep={spec!r}: expected field=v1,v2,... or field=[JSON list]")
    field, values = spec.split("=", 1)
    if values.lstrip().startswith("["):  # values that hold commas, e.g. view lists
      try:
        items = json.loads(values)
      except json.JSONDecodeError as e:
        raise ValueError(f"--sweep={spec!r}: the list is not JSON ({e})") from e
      if not isinstance(items, list) or not items:
        raise ValueError(f"--sweep={spec!r}: expected a non-empty JSON list")
      axes.append([(field, _convert(config, field, str(v))) for v in items])
    else:
      axes.append([(field, _convert(config, field, v)) for v in values.split(",") if v])
  return [list(p) for p in itertools.product(*axes)] if axes else [[]]


def label(point):
  return ",".join(f"{f}={v:g}" if isinstance(v, float) else f"{f}={v}" for f, v in point) or "base"


def run_point(compose, point, workdir, dataset, with_criterion):
  c = compose(point)
  wd = os.path.join(workdir, label(point))
  if any(f.startswith("data.") for f, _ in point):  # this point's own views or scene
    dataset = datasets.load(c.data, wd)
  infos = pipeline.run(c, wd, dataset)
  last = infos.get(c.final_stage) or infos[pipeline.parse_stages(c.stages, c)[-1]]
  ev = last.get("eval", {})
  row = {"point": {f: v for f, v in point}, "label": label(point),
         "psnr": ev.get("psnr"), "ssim": ev.get("ssim"), "lpips": ev.get("lpips"),
         "wall_s": sum(i["wall_s"] for i in infos.values()), "criterion": None}
  if with_criterion and "lo" in infos:
    lo = stages.load(wd, "lo", radiance.init_params(c, "lo", dataset))
    render = tuning.lo_renderer(c, dataset, lo)
    row["criterion"] = tuning.criterion_of(render, dataset, c)["criterion"]
  return row


def report(rows, workdir):
  table = tables.markdown(
      ["point", "criterion", "held-out PSNR", "SSIM", "LPIPS", "train s"],
      [[r["label"], tables.cell(r["criterion"], ".3f"), tables.cell(r["psnr"], ".2f"),
        tables.cell(r["ssim"], ".3f"), tables.cell(r["lpips"], ".3f"), f"{r['wall_s']:.0f}"]
       for r in rows]) + "\n"
  with open(os.path.join(workdir, "results.md"), "w") as f:
    f.write(table)
  plots.criterion_and_psnr([r["label"] for r in rows], [r["criterion"] for r in rows],
                           [r["psnr"] for r in rows], os.path.join(workdir, "sweep.png"))
  return table


def main(argv):
  del argv
  with launch(FLAGS.workdir):
    run(config_of_flags(FLAGS["config"], FLAGS.method),
        lambda point: config_of_flags(FLAGS["config"], FLAGS.method, dict(point)))


def run(config, compose):
  """The experiment in FLAGS.workdir (locked by main): `config` is the
  base point's, compose(point) a point's (its fields as overrides, so that
  what the method derives from a swept field follows it)."""
  os.makedirs(FLAGS.workdir, exist_ok=True)
  points = parse_sweeps(config, FLAGS.sweep)
  dataset = datasets.load(config.data, FLAGS.workdir)
  rows = []
  for point in progress.steps(points, "points", "sweep"):
    rows.append(run_point(compose, point, FLAGS.workdir, dataset, FLAGS.criterion))
    with open(os.path.join(FLAGS.workdir, "results.json"), "w") as f:
      json.dump({"points": rows}, f, indent=1)
  print(report(rows, FLAGS.workdir))


def cli():
  """The halo-sweep console script."""
  define_flags()
  run_app(main)


if __name__ == "__main__":
  cli()
