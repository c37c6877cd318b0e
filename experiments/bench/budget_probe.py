"""What sets HALO's margin at a budget, measured on a finished HALO run and
the nerf_tuned run of the same scene, seed and suite:

- Hi-NeRF's samples. On the same held-out views (a regular pixel grid of
  them, MAX_RAYS at most: the file's pixel_stride), Hi's trained field is
  rendered with its own sampler (as it was scored), with twice its samples,
  stratified over the whole [near, far] at its own count, at nerf_tuned's
  and at twice that; nerf_tuned as scored and with twice its samples.
  `one_at_a_time` lists the differences that change one thing: the kind at
  an equal count (what the window does), the count at an equal kind (what
  more samples do); the two fields at equal dense sampling compare the
  fields themselves.
- The ray field's depth. On the rays that both Hi's field and nerf_tuned
  see as opaque: how far it lies from each one's surface (the depth of the
  largest weight, densely sampled), the share of those rays whose surface
  falls inside the guided window, and the share of Hi's squared error that
  lies on the opaque rays whose window misses Hi's own surface.
- L_empty. Its weighted share of Hi's loss over the first and last quarter
  of the stage (the run's metrics.jsonl), and, on a white-background scene,
  the opacity Hi, nerf_tuned and Lo-NeRF put on the pixels the ground truth
  shows as background (floaters), with the share of them Lo sees empty
  (where L_empty can act).

Hi − Lo is in the run's record already. Each probe is a file
results/<suite>/probe/<scene>/seed<k>.json that the budget study's page
reads; it needs the runs' workdirs (their --scratch folders; a suite record adopted
from a study's run is found in that run's), so it runs on the
machine that trained them:

  python -m experiments.bench.budget_probe --suite=budget_960 --scratch=/tmp/bud_s0,/tmp/twin
"""
import json
import math
import os
import sys

from absl import flags, logging
import jax
import numpy as np

from halo_jax import frozen, metrics, progress, raycast, restore, sampler_switch, samplers
from experiments.bench import git_state
from experiments.bench import run_file, selection, suites, tool
from experiments.bench.paths import REPO, result_path, workdirs_of
from experiments.bench.report_common import BASELINE
from halo_jax.geometry import Geometry
from halo_jax.stages import base, metrics_log, radiance

METHOD = "halo"
OPAQUE = 0.5          # acc above which a ray counts as hitting a surface
WHITE = 0.99          # a ground-truth pixel whose every channel is above this is background
MAX_RAYS = 131072     # rays a probe renders per sampler: a pixel grid over every view
QUARTER = 0.25        # the share of Hi's logged steps at each end for L_empty's share


def probe_path(results, suite_name, scene, seed):
  return os.path.join(results, suite_name, "probe", scene, f"seed{seed}.json")


def probe_rays(views, max_rays=MAX_RAYS):
  """(origins, dirs [V, h, w, 3], times [V, h, w, 1] or None, ground truth
  [V, h, w, 3], stride): every view's pixels on a regular grid of this
  stride, the smallest that keeps them within max_rays."""
  o, d = views.rays()
  t = views.ray_times()
  v, h, w = o.shape[:3]
  stride = max(1, math.ceil(math.sqrt(v * h * w / max_rays)))
  grid = (slice(None), slice(None, None, stride), slice(None, None, stride))
  return (o[grid], d[grid], None if t is None else t[grid], np.asarray(views.images)[grid],
          stride)


def _render(render_fn, rays, chunk):
  o, d, t = rays[:3]
  return {k: np.asarray(v) for k, v in raycast.render_chunked(render_fn, o, d, chunk, t).items()}


def _psnr_mean(rgb, gt) -> float:
  """Mean over views of per-view PSNR, as the records score it."""
  return float(np.mean(metrics.psnr(np.clip(rgb, 0.0, 1.0), gt)))


def with_sampler(config, name, **fields):
  """A copy of `config` whose stage `name` renders with these sampler fields."""
  return frozen.replaced(config, {f"{name}.sampler.{k}": v for k, v in fields.items()})


def guide_depth(config, dataset, states, o, d, chunk):
  """(the ray field's depth [V, H, W], the guided sampler's config) of Hi's
  guide, or None where Hi has no 3D guide (unguided or a light field)."""
  g = radiance.guide(config, "hi", dataset, states)
  if g is None or g[0].geometry not in (Geometry.SPHERE, Geometry.NDC):
    return None
  guide, sampler_cfg = g
  depth_of = jax.jit(lambda o, d: {"depth": raycast.ray_field_depth(guide, o, d)[0]})
  return raycast.render_chunked(depth_of, o, d, chunk)["depth"], sampler_cfg


def window_facts(depth, sampler_cfg, near, far, own, other, opaque, sq_err) -> dict:
  """The guided window against the surfaces (depth_max) of Hi's densely
  rendered field (`own`) and of nerf_tuned (`other`) on `opaque` rays;
  depth, own, other, opaque [V, H, W]; sq_err [V, H, W] Hi's squared error
  as trained. Distances are in shares of far − near."""
  lo, hi = (np.asarray(x) for x in samplers.depth_window(depth, near, far, sampler_cfg.window,
                                                          sampler_cfg.near_only))
  span = far - near
  inside = lambda s: (s >= lo) & (s <= hi)
  miss = opaque & ~inside(own)
  return {
      "window": float(sampler_cfg.window), "num_samples": int(sampler_cfg.num_samples),
      "mean_window_share": float(np.mean(hi - lo) / span),
      "opaque_share": float(np.mean(opaque)),
      "median_to_hi_surface": float(np.median(np.abs(depth - own)[opaque]) / span),
      "median_to_baseline_surface": float(np.median(np.abs(depth - other)[opaque]) / span),
      "median_hi_to_baseline_surface": float(np.median(np.abs(own - other)[opaque]) / span),
      "hi_surface_in_window": float(np.mean(inside(own)[opaque])),
      "baseline_surface_in_window": float(np.mean(inside(other)[opaque])),
      "error_share_where_window_misses": float(sq_err[miss].sum() / max(sq_err.sum(), 1e-12)),
      "ray_share_where_window_misses": float(np.mean(miss)),
  }


def empty_share(workdir, weight):
  """{'first', 'last'}: L_empty's weighted value over Hi's loss, mean over
  the first and last QUARTER of Hi's logged steps; None without the term."""
  if weight <= 0:
    return None
  rows = [r for r in metrics_log.read(workdir) if r.get("stage") == "hi" and "empty" in r and r.get("loss")]
  if not rows:
    return None
  share = np.array([weight * r["empty"] / r["loss"] for r in rows])
  k = max(1, int(len(share) * QUARTER))
  return {"first": float(np.mean(share[:k])), "last": float(np.mean(share[-k:]))}


def background_facts(halo_dir, gt, hi_acc, baseline_acc, rays, chunk, tau) -> dict:
  """Opacity on the pixels the ground truth shows as white background: Hi's,
  nerf_tuned's and, where HALO has one, Lo-NeRF's, with the share of those
  pixels Lo sees empty (opacity under L_empty's tau: where L_empty can act)."""
  background = np.all(gt > WHITE, -1)
  out = {METHOD: float(np.mean(hi_acc[background])),
         BASELINE: float(np.mean(baseline_acc[background])),
         "pixel_share": float(np.mean(background))}
  if restore.finished(halo_dir, "lo"):
    lo_acc = _render(restore.load(halo_dir, "lo").render, rays, chunk)["acc"][background]
    out.update(lo=float(np.mean(lo_acc)), lo_sees_empty=float(np.mean(lo_acc < tau)))
  return out


def one_at_a_time(labels, psnr) -> list:
  """The renders' differences that change one thing: the sampler's kind at
  an equal sample count, or the count at an equal kind, on the same field.
  labels {render: (field, sampler kind, samples)}, psnr {render: dB} ->
  [{'field', 'change': 'kind'|'count', 'from', 'to', 'kind'|'samples',
  'delta_db'}], `to` − `from`."""
  by = {v: k for k, v in labels.items()}
  out = []
  for (field, kind, n), key in sorted(by.items()):
    for (f2, k2, n2), key2 in sorted(by.items()):
      if f2 != field or key2 == key:
        continue
      if n2 == n and kind != "stratified" and k2 == "stratified":
        out.append({"field": field, "change": "kind", "samples": n, "from": key2, "to": key,
                    "delta_db": psnr[key] - psnr[key2]})
      elif k2 == kind and n2 == 2 * n:
        out.append({"field": field, "change": "count", "kind": kind, "from": key, "to": key2,
                    "delta_db": psnr[key2] - psnr[key]})
  return out


def _check_workdir(run, record, path):
  """A workdir that is not the record's run (another step count) is refused."""
  want = record["stages"]["hi"]["step"]
  if int(run.states["hi"].step) != want:
    raise ValueError(f"{run.workdir}: Hi-NeRF stopped at step {int(run.states['hi'].step)}, "
                     f"but {path} records {want}; it is not that run's workdir")


def as_scored(run):
  """The run's config with Hi sampling as it was scored: past its sampler
  switch (halo_jax/sampler_switch.py), the switched sampler and no switch
  left, so the probe's sampler fields replace what was rendered."""
  if sampler_switch.after(run.config.hi, int(run.states["hi"].step)):
    return sampler_switch.switched(run.config, "hi")
  return run.config


def probe(halo_dir, baseline_dir, halo_record, baseline_record, paths) -> dict:
  """The probe's figures for one scene and seed (see the module docstring)."""
  halo, other = restore.load(halo_dir, "hi"), restore.load(baseline_dir, "hi")
  _check_workdir(halo, halo_record, paths[0])
  _check_workdir(other, baseline_record, paths[1])
  ds, views, chunk = halo.dataset, halo.dataset.test, halo.config.eval.chunk
  near, far = float(ds.near), float(ds.far)
  rays = probe_rays(views)
  gt = rays[3]
  scored = {id(halo): as_scored(halo), id(other): as_scored(other)}
  n_own = int(scored[id(halo)].hi.sampler.num_samples)
  n_theirs = int(scored[id(other)].hi.sampler.num_samples)
  variants = {  # (run, sampler fields or None for the run's own)
      "own": (halo, None), "own_twice_samples": (halo, dict(num_samples=2 * n_own)),
      "stratified_own_count": (halo, dict(kind="stratified", num_samples=n_own)),
      "baseline_sampler": (halo, dict(kind="stratified", num_samples=n_theirs)),
      "twice_baseline_samples": (halo, dict(kind="stratified", num_samples=2 * n_theirs)),
      BASELINE: (other, None),
      f"{BASELINE}_twice_samples": (other, dict(kind="stratified", num_samples=2 * n_theirs))}
  renders = {}
  for key, (run, fields) in progress.steps(list(variants.items()), "renders", "probe renders"):
    fn = run.render if fields is None else base.renderer_of(
        with_sampler(scored[id(run)], "hi", **fields), "hi", ds, run.states)
    renders[key] = _render(fn, rays, chunk)
  own, baseline = renders["own"], renders[BASELINE]
  out = {"scene_views": list(views.names), "pixel_stride": rays[4], "near": near, "far": far,
         "samplers": {k: dict(f or {}) for k, (_, f) in variants.items()},  # {}: as trained
         "hi_sampler": {"kind": scored[id(halo)].hi.sampler.kind, "num_samples": n_own},
         "psnr": {k: _psnr_mean(r["rgb"], gt) for k, r in renders.items()},
         "record_psnr": {METHOD: halo_record["psnr"], BASELINE: baseline_record["psnr"]}}
  labels = {k: (METHOD if run is halo else BASELINE,
                (f or {}).get("kind", scored[id(run)].hi.sampler.kind),
                int((f or {}).get("num_samples", scored[id(run)].hi.sampler.num_samples)))
            for k, (run, f) in variants.items()}
  out["one_at_a_time"] = one_at_a_time(labels, out["psnr"])
  dense = renders["twice_baseline_samples"]
  opaque = (dense["acc"] > OPAQUE) & (baseline["acc"] > OPAQUE)
  g = guide_depth(halo.config, ds, halo.states, rays[0], rays[1], chunk)
  if g is not None:
    sq_err = np.sum((np.clip(own["rgb"], 0, 1) - gt) ** 2, -1)
    out["guide"] = window_facts(g[0], g[1], near, far, dense["depth_max"],
                                baseline["depth_max"], opaque, sq_err)
  out["empty_share"] = empty_share(halo_dir, float(halo.config.hi.empty.weight))
  if ds.white_background:
    out["background_acc"] = background_facts(halo_dir, gt, own["acc"], baseline["acc"], rays,
                                             chunk, float(halo.config.hi.empty.tau))
  return out


def _finished_workdir(scratches, record, mode, scene, method, seed):
  """The first workdir of the record's run under `scratches` whose Hi-NeRF
  finished at the record's step (paths.workdirs_of); None where none
  finished; ValueError where those that did stopped at other steps."""
  want = record["stages"]["hi"]["step"]
  finished = [d for scratch in scratches
              for d in workdirs_of(scratch, record, mode, scene, method, seed)
              if restore.finished(d, "hi")]
  for d in finished:
    if _stopped_at(d) == want:
      return d
  if finished:
    raise ValueError(f"{finished[0]}: Hi-NeRF stopped at step {_stopped_at(finished[0])}, but "
                     f"its record has {want}; it is not that run's workdir")
  return None


def _stopped_at(workdir) -> int:
  with open(os.path.join(workdir, "hi", "final", "info.json")) as f:
    return int(json.load(f)["step"])


def probe_run(suite_name, mode, scene, seed, results, scratches):
  """Probes `scene`/seed`seed` of a suite and writes its file; None (nothing
  written) unless both methods' records, and their finished workdirs under
  one of `scratches`, are there."""
  paths = [result_path(results, suite_name, mode, scene, m, seed) for m in (METHOD, BASELINE)]
  if not all(os.path.exists(p) for p in paths):
    return None
  records = [run_file.read(p) for p in paths]
  dirs = [_finished_workdir(scratches, r, mode, scene, m, seed)
          for r, m in zip(records, (METHOD, BASELINE))]
  if None in dirs:
    return None
  out = probe(*dirs, *records, paths)
  out.update(scene=scene.name, seed=seed, suite=suite_name,
             runs={m: {"code_tree": r["provenance"]["git"].get("code_tree"),
                       "commit": r["provenance"]["git"]["commit"]}
                   for m, r in zip((METHOD, BASELINE), records)},
             provenance=git_state.collect(measure_peak=False))
  run_file.write_json(probe_path(results, suite_name, scene.name, seed), out)
  return out


FLAGS = flags.FLAGS


def define_flags():
  flags.DEFINE_enum("suite", "budget_960", sorted(suites.SUITES), "The suite whose runs to probe.")
  flags.DEFINE_string("mode", "budget", "The suite's mode.")
  flags.DEFINE_string("results", os.path.join(REPO, "results"),
                      "Where the runs' records are and the probes go.")
  flags.DEFINE_list("scratch", ["/tmp/halo_bench"], "Folders holding the runs' workdirs "
                    "(benchmark's and ablations.py's --scratch), searched in order.")
  flags.DEFINE_string("only", "", "Probe only 'scene/seed<k>' matching this regex.")


def main(argv):
  del argv
  logging.set_verbosity(logging.WARNING)
  suite = suites.SUITES[FLAGS.suite]
  pairs = [(s, k) for k in range(max(s.seeds for s in suite.scenes)) for s in suite.scenes
           if k < s.seeds]
  try:
    pairs = selection.select(pairs, lambda p: f"{p[0].name}/seed{p[1]}", FLAGS.only, "scene",
                             "suite")
  except ValueError as e:
    sys.exit(str(e))
  for scene, seed in pairs:
    out = probe_run(FLAGS.suite, FLAGS.mode, scene, seed, FLAGS.results, FLAGS.scratch)
    tag = f"{scene.name}/seed{seed}"
    if out is None:
      print(f"skipped  {tag}: needs both records and both workdirs in --scratch", flush=True)
    else:
      print(f"probed   {tag}: " + ", ".join(f"{k} {v:.2f}" for k, v in out["psnr"].items()),
            flush=True)


def cli():
  """The tool's entry point (python -m experiments.<tool>)."""
  define_flags()
  tool.run(sys.modules[__name__], main)


if __name__ == "__main__":
  cli()
