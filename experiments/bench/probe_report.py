"""The budget study page's section on the probes (budget_probe.py): where
HALO falls short at each budget and why, the re-rendered PSNRs, and the
differences that change one thing at a time."""
import os

import numpy as np

from experiments.bench import run_file, suites
from experiments.bench.paths import REPO
from experiments.bench.report_common import BASELINE

METHOD = "halo"


def probes(results, scenes=suites.BUDGET_SCENES) -> dict:
  """{(budget_s, scene): [probe, ...]} of the study's probe files
  (budget_probe.py) under `results`, for `scenes`."""
  out = {}
  for name, budget_s in suites.BUDGET_STUDY.items():
    for scene in scenes:
      folder = os.path.join(results, name, "probe", scene)
      if os.path.isdir(folder):
        out[(budget_s, scene)] = [run_file.read(os.path.join(folder, f))
                                  for f in sorted(os.listdir(folder)) if f.endswith(".json")]
  return {k: v for k, v in out.items() if v}


def _mean(ps, *keys):
  """Mean over probes of ps[i][keys[0]][keys[1]]...; None where one lacks it."""
  vals = []
  for p in ps:
    for k in keys:
      p = p.get(k) if isinstance(p, dict) else None
    vals.append(p)
  return None if any(v is None for v in vals) else float(np.mean(vals))


# Another sampler counts as capping Hi's field when it adds this much to it;
# samplers within TIE_DB of each other count as equal.
SAMPLER_DB, TIE_DB = 0.1, 0.05
OTHER_SAMPLERS = {"own_twice_samples": "twice its own samples",
                  "baseline_sampler": f"{BASELINE}'s sampler",
                  "twice_baseline_samples": f"{BASELINE}'s sampler at twice its samples"}


def probe_reading(ps, gain_on_lo=None) -> str:
  """The probes' verdict: whether Hi's field or its sampler sets the margin,
  and whether Hi gains on Lo (`gain_on_lo`: Hi − Lo from the records)."""
  own = _mean(ps, "psnr", "own")
  gap = _mean(ps, "psnr", "twice_baseline_samples") - _mean(ps, "psnr",
                                                            f"{BASELINE}_twice_samples")
  top = max(_mean(ps, "psnr", k) for k in OTHER_SAMPLERS)
  # the first (the cheapest) of the other samplers within a rounding of the best
  best = next(k for k in OTHER_SAMPLERS if _mean(ps, "psnr", k) >= top - TIE_DB)
  gain = _mean(ps, "psnr", best) - own
  text = (f"at equal dense sampling Hi's field is {'ahead of' if gap >= 0 else 'behind'} "
          f"{BASELINE}'s ({gap:+.2f} dB)")
  if gain >= SAMPLER_DB:
    text += (f"; Hi's own sampler costs it {gain:.2f} dB more ({OTHER_SAMPLERS[best]} "
             "recovers it)")
  elif gap < 0:
    text += ": the margin is lost in training, not in the sampler"
  if gain_on_lo is not None:
    text += (f"; Hi {'gains' if gain_on_lo > 0 else 'loses'} {abs(gain_on_lo):.2f} dB on "
             "halo's own Lo-NeRF")
  return f"Reading: {text}."


def probe_sentences(ps) -> list:
  """What the probes of one scene and budget measured, in words."""
  own, own2 = _mean(ps, "psnr", "own"), _mean(ps, "psnr", "own_twice_samples")
  field2, base2 = (_mean(ps, "psnr", "twice_baseline_samples"),
                   _mean(ps, "psnr", f"{BASELINE}_twice_samples"))
  lines = [f"Twice the samples at evaluation: Hi {own2 - own:+.2f} dB with its own sampler, "
           f"{BASELINE} {base2 - _mean(ps, 'psnr', BASELINE):+.2f} dB. With {BASELINE}'s "
           f"sampler at twice its samples, Hi's field is {field2 - base2:+.2f} dB from "
           f"{BASELINE}'s."]
  if _mean(ps, "guide", "window") is not None:
    lines.append(
        f"The ray field's window spans {100 * _mean(ps, 'guide', 'mean_window_share'):.0f}% "
        f"of [near, far] ({ps[0]['guide']['num_samples']} samples) and holds Hi's surface on "
        f"{100 * _mean(ps, 'guide', 'hi_surface_in_window'):.1f}% of the opaque rays; the "
        "rays it misses carry "
        f"{100 * _mean(ps, 'guide', 'error_share_where_window_misses'):.1f}% of Hi's squared "
        f"error. Its depth is {100 * _mean(ps, 'guide', 'median_to_hi_surface'):.1f}% of the "
        "range from Hi's surface (median); Hi's and nerf_tuned's surfaces are "
        f"{100 * _mean(ps, 'guide', 'median_hi_to_baseline_surface'):.1f}% apart.")
  if _mean(ps, "empty_share", "first") is not None:
    lines.append(f"L_empty is {100 * _mean(ps, 'empty_share', 'first'):.2f}% of Hi's loss over "
                 f"its first quarter and {100 * _mean(ps, 'empty_share', 'last'):.2f}% over "
                 "its last.")
  if _mean(ps, "background_acc", METHOD) is not None:
    lo = _mean(ps, "background_acc", "lo")
    lines.append(f"Opacity on the background pixels: halo "
                 f"{_mean(ps, 'background_acc', METHOD):.4f}, {BASELINE} "
                 f"{_mean(ps, 'background_acc', BASELINE):.4f}" + (
                     "" if lo is None else f", halo's Lo-NeRF {lo:.4f}, which sees "
                     f"{100 * _mean(ps, 'background_acc', 'lo_sees_empty'):.0f}% of them "
                     "empty (where L_empty can act)") + ".")
  return lines


def probe_section(by_key, by_budget, hi_minus_lo, lead, overfit=None) -> list:
  """The page's section on the probes: where HALO falls short at each
  budget and why, a table of re-rendered PSNRs and, per scene and budget,
  what they say (by_budget: study()'s records, for the leads and Hi − Lo;
  overfit(runs): a sentence on halo's held-out curve falling, or '')."""
  if not by_key:
    return []
  reading = {k: probe_reading(ps, hi_minus_lo(by_budget.get(k[0], {}).get(k[1], {})))
             for k, ps in by_key.items()}
  cols = ("own", "own_twice_samples", "baseline_sampler", "twice_baseline_samples", BASELINE,
          f"{BASELINE}_twice_samples")
  out = ["## What sets the margin", "",
         "`python -m experiments.bench.budget_probe --suite=SUITE --scratch=DIR` re-renders a "
         "finished pair of runs (halo and nerf_tuned, one scene and seed) on the same "
         "validation views: Hi-NeRF's trained field with its own sampler (as scored), with "
         "twice its samples, with nerf_tuned's stratified sampler and with twice that; "
         "nerf_tuned as scored and with twice its samples. It also measures the ray field's "
         "window against each field's surface (the depth of the largest weight, on the rays "
         "both see as opaque), L_empty's share of Hi's loss, and the opacity on background "
         "pixels. Mean over the probed seeds (in brackets).", "",
         *shortfalls(by_key, by_budget, hi_minus_lo, lead, reading, overfit),
         "| budget | scene | Hi as scored | Hi, 2× its samples | Hi, nerf_tuned's sampler | "
         "Hi, 2× that | nerf_tuned | nerf_tuned, 2× |", "|---|---|---|---|---|---|---|---|"]
  in_order = sorted(by_key.items(), key=lambda kv: (suites.BUDGET_SCENES.index(kv[0][1]),
                                                    kv[0][0]))
  for (b, scene), ps in in_order:
    out.append(f"| {b:g} s | {scene} ({len(ps)}) | " + " | ".join(
        "-" if _mean(ps, "psnr", c) is None else f"{_mean(ps, 'psnr', c):.2f}" for c in cols)
        + " |")
  out += ["", *retrained_lines(by_key, by_budget)]
  strides = sorted({p.get("pixel_stride") for ps in by_key.values() for p in ps} - {None})
  out += ["PSNRs on a regular grid of the views' pixels (a stride of "
          f"{', '.join(map(str, strides))} pixels in each direction, by scene), not on every "
          "pixel: small differences are the grid's as much as the samplers'.", ""]
  for (b, scene), ps in in_order:
    out += [f"- **{scene} at {b:g} s.** {reading[(b, scene)]} " + " ".join(probe_sentences(ps))]
  return out + [""] + one_at_a_time_lines(in_order)


# A probed run whose record differs from the suite's record of the same
# scene, method and seed by more than this was trained again, not the same.
SAME_RUN_DB = 0.005


def retrained_lines(by_key, by_budget) -> list:
  """A sentence naming the probes whose runs score otherwise than the suite's
  records of the same seed (trained again, on another host or with the
  config of an older commit): their readings are of those runs."""
  diffs = []
  for (b, scene), ps in sorted(by_key.items()):
    for p in ps:
      for method, mine in sorted(p.get("record_psnr", {}).items()):
        suite = [r["psnr"] for r in by_budget.get(b, {}).get(scene, {}).get(method, [])
                 if r.get("seed") == p.get("seed")]
        if suite and abs(mine - suite[0]) > SAME_RUN_DB:
          diffs.append(f"{scene} at {b:g} s, {method} seed {p.get('seed')}: "
                       f"{mine:.2f} against {suite[0]:.2f} dB")
  if not diffs:
    return []
  return ["These probes re-render runs trained again for them, which score otherwise than "
          "the suite's record of the same scene, method and seed (another host's CPU, or "
          "an older config: docs/notes/2026-11-28-keep-lead.md); their readings are of the "
          "probed runs: " + "; ".join(diffs) + ".", ""]


def _studies_of(scene, budget_s) -> str:
  """' Studies: [name](page), ...' of the budget studies at `budget_s` whose
  scenes include `scene` and whose page is written ('' where none)."""
  from experiments.bench import budget_studies  # pylint: disable=import-outside-toplevel
  names = [n for n, st in budget_studies.STUDIES.items()
           if st.budget_s == budget_s and any(s.name == scene for s in st.scenes)
           and os.path.exists(os.path.join(REPO, "docs", "results", f"ablation_{n}.md"))]
  return (" Studies: " + ", ".join(f"[{n}](ablation_{n}.md)" for n in names) + "."
          if names else "")


def shortfalls(by_key, by_budget, hi_minus_lo, lead, reading, overfit=None) -> list:
  """A line per scene and budget where halo trails nerf_tuned or Hi-NeRF
  ends under its own Lo-NeRF, with the probe's reading at that budget (or
  the nearest budget's where that one is not probed) and `overfit(runs)`."""
  out = []
  for scene in suites.BUDGET_SCENES:
    for b in sorted(by_budget):
      runs = by_budget[b].get(scene, {})
      x, gain = lead(runs), hi_minus_lo(runs)
      what = ([f"halo − {BASELINE} {x:+.2f} dB"] if x is not None and x < 0 else []) + (
          [f"Hi − Lo {gain:+.2f} dB"] if gain is not None and gain < 0 else [])
      if not what:
        continue
      probed = sorted((abs(pb - b), pb) for pb, ps in by_key if ps == scene)
      where = ("Not probed." if not probed else reading[(probed[0][1], scene)]
               if probed[0][0] == 0 else f"Not probed at {b:g} s; the {probed[0][1]:g}-s "
               "probe's r" + reading[(probed[0][1], scene)][1:])
      note = overfit(runs) if overfit else ""
      out.append(f"- **{scene} at {b:g} s**: {', '.join(what)}. {where}"
                 + (f" {note}" if note else "") + _studies_of(scene, b))
  return (["Where HALO falls short (the scene, the budget, and what the probe nearest "
           "to it measured):", "", *out, ""] if out else [])


def one_at_a_time_lines(in_order) -> list:
  """The probes' differences that change one thing (budget_probe.one_at_a_time),
  mean over seeds; older probe files, without them, are named."""
  rows, old = [], []
  for (b, scene), ps in in_order:
    found = [p["one_at_a_time"] for p in ps if "one_at_a_time" in p]
    if not found:
      old.append(f"{scene} at {b:g} s")
      continue
    for i, c in enumerate(found[0]):
      what = (f"{c['kind']}: {c['from']} -> {c['to']} (twice the samples)"
              if c["change"] == "count" else
              f"{c['samples']} samples: {c['from']} -> {c['to']} (the window)")
      delta = np.mean([f[i]["delta_db"] for f in found])
      rows.append(f"| {b:g} s | {scene} ({len(found)}) | {c['field']} | {what} | {delta:+.2f} |")
  out = ["### One thing at a time", ""]
  if rows:
    out += ["| budget | scene | field | change | dB |", "|---|---|---|---|---|", *rows, ""]
  if old:
    out += ["Probe files made before the probe compared one thing at a time (their "
            "\"nerf_tuned's sampler\" column changes both the kind and the count): "
            + "; ".join(old) + ". They are read above as they stand until rerun.", ""]
  return out


def other_scenes_section(results, behind=None) -> list:
  """The probes of the validation scenes beyond the study's four (the 960-s
  runs on every validation scene): the re-rendered PSNRs and the reading,
  led by the margin where halo is behind ({scene: halo − nerf_tuned dB} at
  the last budget): there the reading is the shortfall's mechanism."""
  behind = behind or {}
  others = tuple(s.name for s in suites.VALIDATION_SCENES if s.name not in suites.BUDGET_SCENES)
  by_key = probes(results, others)
  if not by_key:
    return []
  cols = ("own", "own_twice_samples", "baseline_sampler", "twice_baseline_samples", BASELINE,
          f"{BASELINE}_twice_samples")
  out = ["### Probes of the other scenes", "",
         "The same probe on the pairs of the other validation scenes whose workdirs a "
         "session kept (seeds in brackets):", "",
         "| budget | scene | Hi as scored | Hi, 2× its samples | Hi, nerf_tuned's sampler | "
         "Hi, 2× that | nerf_tuned | nerf_tuned, 2× |", "|---|---|---|---|---|---|---|---|"]
  in_order = sorted(by_key.items(), key=lambda kv: (others.index(kv[0][1]), kv[0][0]))
  for (b, scene), ps in in_order:
    out.append(f"| {b:g} s | {scene} ({', '.join(str(p.get('seed')) for p in ps)}) | "
               + " | ".join("-" if _mean(ps, "psnr", c) is None
                            else f"{_mean(ps, 'psnr', c):.2f}" for c in cols) + " |")
  out.append("")
  last = max(b for b, _ in by_key)
  for (b, scene), ps in in_order:
    short = (f" halo − {BASELINE} {behind[scene]:+.2f} dB: a goal's shortfall."
             if b == last and scene in behind else "")
    out.append(f"- **{scene} at {b:g} s.**{short} {probe_reading(ps)}")
  return out + [""]


def dense_eval_section(results, scenes, budget_s: float) -> list:
  """The free check of dense evaluation at `budget_s` on `scenes` (those
  whose Hi the window samples): from the probes, each method's held-out
  PSNR as scored and rendered densely (halo's Hi: nerf_tuned's sampler at
  its scored count, `baseline_sampler`; nerf_tuned: its samples doubled),
  and halo's margin with neither, halo alone, and both rendered
  densely (the same chance for the baseline)."""
  by_key = probes(results, tuple(s.name for s in scenes))
  ps_of = [(scene, ps) for (b, scene), ps in sorted(
      by_key.items(), key=lambda kv: [s.name for s in scenes].index(kv[0][1])) if b == budget_s]
  if not ps_of:
    return []
  rows, moves = [], {"halo": [], "both": []}
  for scene, ps in ps_of:
    own, dense = _mean(ps, "psnr", "own"), _mean(ps, "psnr", "baseline_sampler")
    base, base2 = _mean(ps, "psnr", BASELINE), _mean(ps, "psnr", f"{BASELINE}_twice_samples")
    moves["halo"].append(dense - own)
    moves["both"].append((dense - base2) - (own - base))
    count = "/".join(sorted({str(p.get("samplers", {}).get("baseline_sampler", {}).get(
        "num_samples", "?")) for p in ps}))
    rows.append(f"| {scene} ({', '.join(str(p.get('seed')) for p in ps)}) | {own:.2f} | "
                f"{dense:.2f} ({count}) | {base:.2f} | {base2:.2f} | {own - base:+.2f} | "
                f"{dense - base:+.2f} | {dense - base2:+.2f} |")
  return [f"### Dense evaluation at {budget_s:g} s: the free check", "",
          "Hi trained as it is, its held-out views rendered with the probed "
          f"{BASELINE}'s sampler at the count it was scored with (stratified over the whole "
          "ray; the count in brackets: 128 where that run was past its switch), beside "
          f"{BASELINE} rendered with twice its samples (the same chance for the baseline), "
          "from the probes above (seeds in brackets; the probes' pixel grid; `window`: Hi's "
          "own sampler, as it trains). The rule's verdicts on dense renders, on "
          "every validation view, are the `hi_window` studies' (`dense_eval_2000`: 64 "
          "samples; `samples_64_after_2000+dense_eval_128`: today's default):", "",
          f"| scene | halo, window | halo, dense | {BASELINE} | {BASELINE}, 2× | Δ, window | "
          "Δ, halo dense | Δ, both dense |", "|---|---|---|---|---|---|---|---|", *rows, "",
          f"Mean over {len(rows)} scenes: dense evaluation adds "
          f"{np.mean(moves['halo']):+.2f} dB to halo (from {min(moves['halo']):+.2f} to "
          f"{max(moves['halo']):+.2f}); with {BASELINE} rendered densely too, halo's margin "
          f"moves {np.mean(moves['both']):+.2f} dB (from {min(moves['both']):+.2f} to "
          f"{max(moves['both']):+.2f}).", ""]
