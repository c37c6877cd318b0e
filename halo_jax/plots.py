"""Plots the experiment scripts share (matplotlib, no display needed)."""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # pylint: disable=g-import-not-at-top


def criterion_and_psnr(labels, criterion, psnr, path, threshold=None, xlabel="",
                       psnr_label="held-out PSNR (dB)", title=""):
  """Held-out PSNR (right axis) and the frequency criterion (left axis) per point.

  Points without a criterion (None) are left out of its line.
  """
  fig, ax = plt.subplots(figsize=(max(6.0, 0.9 * len(labels)), 4))
  x = list(range(len(labels)))
  scored = [(i, c) for i, c in zip(x, criterion) if c is not None]
  if scored:
    ax.plot(*zip(*scored), "o--", color="C0")
    if threshold is not None:
      ax.axhline(threshold, color="C0", ls=":", lw=1)
  ax.set_ylabel("rho (frequency criterion)" + ("; dotted: threshold" if threshold else ""),
                color="C0")
  ax.set_xticks(x)
  ax.set_xticklabels(labels, rotation=30, ha="right", fontsize=8)
  ax.set_xlabel(xlabel)
  ax2 = ax.twinx()
  ax2.plot(x, psnr, "s-", color="C1")
  ax2.set_ylabel(psnr_label, color="C1")
  if title:
    ax.set_title(title, fontsize=10)
  fig.tight_layout()
  fig.savefig(path, dpi=120)
  plt.close(fig)


def training_curves(records, width_px: int = 360, height_px: int = 220):
  """uint8 [H, W, 3]: the training loss (log scale) and held-out PSNR of
  metrics.jsonl records against training seconds, one line per stage."""
  import numpy as np  # pylint: disable=g-import-not-at-top
  fig, (ax_loss, ax_psnr) = plt.subplots(1, 2, figsize=(width_px / 80, height_px / 80), dpi=80)
  for stage in dict.fromkeys(r.get("stage") for r in records):
    rows = [r for r in records if r.get("stage") == stage]
    train = [(r["wall_s"], r["loss"]) for r in rows if "loss" in r and not r.get("heldout")]
    held = [(r["wall_s"], r["psnr"]) for r in rows if r.get("heldout") and "psnr" in r]
    if train:
      ax_loss.plot(*zip(*train), label=stage)
    if held:
      ax_psnr.plot(*zip(*held), marker="o", ms=3, label=stage)
  ax_loss.set_yscale("log")
  ax_loss.set_title("loss", fontsize=8)
  ax_psnr.set_title("held-out PSNR", fontsize=8)
  for ax in (ax_loss, ax_psnr):
    ax.set_xlabel("training s", fontsize=7)
    ax.tick_params(labelsize=6)
  if records:
    ax_loss.legend(fontsize=6)
  fig.tight_layout()
  fig.canvas.draw()
  image = np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()
  plt.close(fig)
  return image
