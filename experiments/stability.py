"""Prints the stability table: every stiff case against its reference.

  python -m experiments.stability [--out=DIR]

Each row is one quantity of one case (experiments/bench/stability_cases.py): its largest
error against a closed form or a float64 numpy reference, the tolerance, and
whether every value and gradient was finite. Exits with status 1 if any row
fails. With --out, also writes DIR/stability.json and DIR/stability.md.
"""
import dataclasses
import json
import os
import sys

from absl import app, flags

from experiments.bench import stability_cases as stability

flags.DEFINE_string("out", "", "folder for stability.json / stability.md (optional)")
FLAGS = flags.FLAGS


def table(checks) -> str:
  lines = ["| case | quantity | max error | tolerance | reference | finite | ok | note |",
           "|---|---|---|---|---|---|---|---|"]
  for c in checks:
    lines.append(f"| {c.case} | {c.quantity} | {c.error:.2e} | {c.tol:.1e} | {c.reference} | "
                 f"{'yes' if c.finite else 'NO'} | {'yes' if c.ok else 'NO'} | {c.note} |")
  return "\n".join(lines)


def main(argv):
  del argv
  checks = stability.run_all()
  text = table(checks)
  print(text)
  failed = [c for c in checks if not c.ok]
  print(f"\n{len(checks) - len(failed)}/{len(checks)} checks within tolerance, "
        f"{sum(not c.finite for c in checks)} with non-finite values or gradients")
  if FLAGS.out:
    os.makedirs(FLAGS.out, exist_ok=True)
    with open(os.path.join(FLAGS.out, "stability.json"), "w") as f:
      json.dump([dict(dataclasses.asdict(c), ok=c.ok) for c in checks], f, indent=1)
    with open(os.path.join(FLAGS.out, "stability.md"), "w") as f:
      f.write(text + "\n")
  sys.exit(1 if failed else 0)


if __name__ == "__main__":
  app.run(main)
