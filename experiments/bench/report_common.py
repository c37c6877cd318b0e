"""What the benchmark's report pages share: the methods' order, the baseline
every method is measured against, and mean ± std cells."""
import numpy as np

from halo_jax import methods

from halo_jax.stages import collapse

METHOD_ORDER = methods.with_role(methods.base.COMPARED, methods.base.REPORTED)
BASELINE = "nerf_tuned"


def in_method_order(by_method):
  """The methods of {method: ...} in METHOD_ORDER, others after, by name."""
  return sorted(by_method, key=lambda m: (METHOD_ORDER.index(m) if m in METHOD_ORDER else 99, m))


def stat(values):
  """'mean +- std' (std over seeds; no +- for one seed)."""
  v = np.asarray([x for x in values if x is not None], np.float64)
  if v.size == 0:
    return "-", None
  return mean_pm(v), float(v.mean())


def mean_pm(v, digits=2):
  """'mean ± std' of an array (std over seeds, ddof 1; the value alone for one)."""
  if v.size == 1:
    return f"{v[0]:.{digits}f}"
  return f"{v.mean():.{digits}f} ± {v.std(ddof=1):.{digits}f}"


def collapsed_stages(record) -> list:
  """The stages of a run's record whose verdict (training fit or held-out
  render; halo_jax/stages/collapse.py) is collapsed."""
  out = [n for n, v in (record.get("learned") or {}).items() if v == collapse.COLLAPSED]
  if "collapsed" in record:
    out.append(record["collapsed"]["stage"])
  out += [n for n, v in (record.get("heldout_learned") or {}).items() if v == collapse.COLLAPSED]
  return sorted(set(out))


def collapsed_methods(by_method, methods) -> list:
  """Which of `methods` have a run of {method: [record, ...]} (one scene)
  with a collapsed stage."""
  return [m for m in methods if any(collapsed_stages(r) for r in by_method.get(m, []))]


def collapse_lines(tagged_records):
  """Markdown lines counting the collapse check's verdicts
  (halo_jax/stages/collapse.py) over [(tag, record)]: how many runs learned,
  which collapsed (tag and stage), which render no better than a constant
  image on held-out views, and how many carry no verdict (recorded before
  the check existed, or too short to judge)."""
  collapsed = [(t, r["collapsed"]) for t, r in tagged_records if "collapsed" in r]
  learned = sum(1 for _, r in tagged_records
                if "collapsed" not in r and "learned" in (r.get("learned") or {}).values())
  other = len(tagged_records) - learned - len(collapsed)
  flat = [(t, n) for t, r in tagged_records
          for n, v in (r.get("heldout_learned") or {}).items() if v == collapse.COLLAPSED]
  lines = [f"Collapse check (each stage's training fit against the best constant "
           f"prediction's; halo_jax/stages/collapse.py): {learned} run(s) learned, "
           f"**{len(collapsed)} collapsed**, {other} without a verdict (recorded before "
           "today's rule, whose words `experiments/rejudge.py` moved to `learned_older_rule`, "
           "or too short past the crop to judge)."
           + (f" **{len(flat)} stage(s) no better than a constant image on held-out views.**"
              if flat else "")]
  for tag, c in collapsed:
    lines.append(f"- collapsed: {tag}, stage `{c['stage']}` ({c['train_psnr']:.2f} dB against "
                 f"the constant's {c['constant_psnr']:.2f})")
  for tag, stage in flat:
    lines.append(f"- constant on held-out views: {tag}, stage `{stage}`")
  return lines
