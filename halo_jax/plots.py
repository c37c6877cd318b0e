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
