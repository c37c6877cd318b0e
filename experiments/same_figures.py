"""One CPU-suite run three ways: alone on one core, on one core beside a busy
process pinned to the same core (about half its speed), and on every core.
Under the 'budget' protocol the first two must train the same steps and give
the same figures; the third shows what XLA's thread count changes (its CPU
reductions split by thread count, so the last bits of every sum can move).

  python -m experiments.same_figures --scene=lego_8view --method=nerf_tuned \
      --out=results/same_figures/lego_8view_nerf_tuned.json

Each way runs in its own process (the core and XLA's threads are fixed before
jax starts) and writes its record's figures; the parent writes them side by
side with the busy process's CPU seconds, which show that it really competed.
Takes about three runs' time (the suite's 240 reference seconds each, plus
evaluation), the second at about half speed.
"""
import json
import multiprocessing
import os
import subprocess
import sys
import tempfile
import time

from absl import app, flags


FLAGS = flags.FLAGS
flags.DEFINE_string("scene", "lego_8view", "a CPU-suite scene")
flags.DEFINE_string("method", "nerf_tuned", "a method of that scene")
flags.DEFINE_integer("seed", 0, "the run's seed")
flags.DEFINE_string("out", "", "JSON file for the three ways' figures")
flags.DEFINE_string("child", "", "internal: run one way ('alone', 'beside_busy', 'all_cores')")
flags.DEFINE_string("child_out", "", "internal: the child's JSON file")

WAYS = ("alone", "beside_busy", "all_cores")


def _busy(core):
  os.sched_setaffinity(0, {core})
  while True:
    pass


def _cpu_seconds(pid) -> float:
  with open(f"/proc/{pid}/stat") as f:
    fields = f.read().rsplit(")", 1)[1].split()
  return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def run_child():
  """One way, in this process: the suite's run, its figures to --child_out."""
  cores = sorted(os.sched_getaffinity(0))
  if FLAGS.child != "all_cores":
    os.sched_setaffinity(0, {cores[0]})
  from halo_jax import runs  # pylint: disable=import-outside-toplevel
  from experiments.bench import benchmark, suites  # pylint: disable=import-outside-toplevel
  scene = next(s for s in suites.CPU.scenes if s.name == FLAGS.scene)
  with tempfile.TemporaryDirectory(prefix="same_figures_") as tmp:
    c = benchmark.configure(suites.CPU, scene, FLAGS.method, FLAGS.seed, "budget", tmp,
                            (("eval.lpips", False),))
    rec = runs.run_method(c, os.path.join(tmp, "run"))
    front = benchmark.front_points(os.path.join(tmp, "run"), rec, with_lpips=False)
  out = {"cores": len(os.sched_getaffinity(0)), "psnr": rec["psnr"], "ssim": rec["ssim"],
         "per_view_psnr": {n: v["psnr"] for n, v in sorted(rec["per_view"].items())},
         "steps": {n: s["step"] for n, s in rec["stages"].items()},
         "front": [[p["at_s"], p.get("step"), p["psnr"]] for p in front],
         "wall_s": rec["wall_s"], "reference_s": rec.get("reference_s")}
  with open(FLAGS.child_out, "w") as f:
    json.dump(out, f)


def main(argv):
  del argv
  if FLAGS.child:
    run_child()
    return
  core = min(os.sched_getaffinity(0))
  result = {"scene": FLAGS.scene, "method": FLAGS.method, "seed": FLAGS.seed, "ways": {}}
  for way in WAYS:
    busy = None
    if way == "beside_busy":
      busy = multiprocessing.Process(target=_busy, args=(core,), daemon=True)
      busy.start()
    with tempfile.NamedTemporaryFile(suffix=".json") as tmp:
      start = time.time()
      subprocess.run([sys.executable, "-m", "experiments.same_figures", f"--child={way}",
                      f"--child_out={tmp.name}",
                      f"--scene={FLAGS.scene}", f"--method={FLAGS.method}",
                      f"--seed={FLAGS.seed}"], check=True,
                     cwd=os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
      with open(tmp.name) as f:
        result["ways"][way] = dict(json.load(f), run_s=round(time.time() - start, 1))
    if busy is not None:
      result["ways"][way]["busy_cpu_s"] = round(_cpu_seconds(busy.pid), 1)
      busy.terminate()
    w = result["ways"][way]
    print(f"{way:12} cores {w['cores']}  steps {w['steps']}  PSNR {w['psnr']:.6f}  "
          f"training {w['wall_s']:.0f} s" + (f"  busy process {w['busy_cpu_s']:.0f} CPU s"
                                             if busy is not None else ""), flush=True)
  ways = result["ways"]
  result["beside_busy_minus_alone_db"] = ways["beside_busy"]["psnr"] - ways["alone"]["psnr"]
  result["all_cores_minus_alone_db"] = ways["all_cores"]["psnr"] - ways["alone"]["psnr"]
  print(f"beside a busy process - alone: {result['beside_busy_minus_alone_db']:+.6f} dB; "
        f"all cores - one core: {result['all_cores_minus_alone_db']:+.6f} dB")
  if FLAGS.out:
    os.makedirs(os.path.dirname(os.path.abspath(FLAGS.out)), exist_ok=True)
    with open(FLAGS.out, "w") as f:
      json.dump(result, f, indent=1)


if __name__ == "__main__":
  app.run(main)
