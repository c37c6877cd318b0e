"""What each added departure recovers of a gap: a study's variant named
`<parent>+<change>` against its parent variant, over the (scene, seed) pairs
both ran, beside the parent's and the child's gap to the study's reference.
(The authors' static study: their recipe, then halo's starts added to it.)"""
import statistics


def _by_pair(recs, variant):
  return {(scene, r["seed"]): r["psnr"] for (scene, v), rs in recs.items() if v == variant
          for r in rs}


def lines(study, recs) -> list:
  """Markdown lines: one row per `<parent>+<change>` variant whose parent is
  also a variant of `study` ([] where there is none)."""
  names = [v.name for v in study.variants]
  ref = _by_pair(recs, study.reference)
  rows = []
  for name in names:
    parent = name.rsplit("+", 1)[0] if "+" in name else ""
    if parent not in names or parent == name:
      continue
    child, base = _by_pair(recs, name), _by_pair(recs, parent)
    pairs = sorted(set(child) & set(base) & set(ref))
    if not pairs:
      rows.append(f"| `{name}` | 0 | | | |")
      continue
    mean = lambda xs: f"{statistics.mean(xs):+.2f}"  # noqa: E731
    rows.append(f"| `{name}` | {len(pairs)} | {mean([base[p] - ref[p] for p in pairs])} | "
                f"{mean([child[p] - ref[p] for p in pairs])} | "
                f"{mean([child[p] - base[p] for p in pairs])} |")
  if not rows:
    return []
  return ["", "## What each change recovers of the gap", "",
          f"Each `<parent>+<change>` variant against its parent over the (scene, seed) pairs "
          f"both (and `{study.reference}`) ran: the parent's gap to `{study.reference}`, what "
          "remains with the change, and what the change recovers.", "",
          f"| variant | pairs | parent − {study.reference} | variant − {study.reference} | "
          "recovered |", "|---|---|---|---|---|"] + rows
