"""TensorBoard event files beside metrics.jsonl (skipped without tensorboardX)."""
import glob
import os
import struct

import jax.numpy as jnp
import numpy as np
import pytest

from halo_jax import checkpoint, defaults
from halo_jax.stages import loop

tensorboardX = pytest.importorskip("tensorboardX")
from tensorboardX.proto import event_pb2  # pylint: disable=g-import-not-at-top,wrong-import-position


def read_events(folder):
  """Every Event in a folder's event files, in file order (TFRecord framing)."""
  out = []
  for path in sorted(glob.glob(os.path.join(folder, "events.out.tfevents.*"))):
    with open(path, "rb") as f:
      data = f.read()
    pos = 0
    while pos < len(data):
      (length,) = struct.unpack("<Q", data[pos:pos + 8])
      out.append(event_pb2.Event.FromString(data[pos + 12:pos + 12 + length]))
      pos += 12 + length + 4
  return out


def scalars(events):
  return [(e.step, v.tag, v.simple_value) for e in events for v in e.summary.value
          if v.HasField("simple_value")]


def _cfg(steps):
  cfg = defaults.base_config().lo  # a stage's config: every field the loop reads
  cfg.update(steps=steps, microbatches=1, lr_init=0.1, lr_final=0.01, max_seconds=0.0,
             log_every=1, checkpoint_every=3, eval_every=2, eval_every_s=0.0, batch_rays=8,
             min_steps=0, max_nonfinite=0)
  return cfg


def _eval(params, step):
  return {"psnr": 10.0 + step, "images": {"v0": np.full((4, 5, 3), 0.5, np.float32)}}


def _loss(p, d, k, s):
  return jnp.sum((p["w"] - d) ** 2), {"psnr": -jnp.sum(p["w"])}


def test_stage_writes_scalars_images_and_a_purge_marker_on_resume(tmp_path):
  wd = str(tmp_path)
  loop.train("lo", _cfg(4), wd, {"w": jnp.zeros(3)}, _loss, jnp.ones(3), seed=0, eval_fn=_eval)
  events = read_events(os.path.join(wd, "tensorboard", "lo"))
  got = scalars(events)
  tags = {t for _, t, _ in got}
  assert {"train/loss", "train/lr", "train/psnr", "train/skipped", "time/wall_s",
          "heldout/psnr"} <= tags
  lr = {s: v for s, t, v in got if t == "train/lr"}
  np.testing.assert_allclose(lr[1], 0.1, rtol=1e-6)  # the rate step 1 used
  assert {s for s, t, _ in got if t == "heldout/psnr"} == {2, 4}
  assert any(v.tag == "heldout/v0" and v.HasField("image") for e in events
             for v in e.summary.value)
  # A killed run resumes from its step-3 checkpoint: the writer marks step 4
  # as the purge point, so TensorBoard drops the first run's later points.
  mngr = checkpoint.manager(os.path.join(wd, "lo", "checkpoints"))
  mngr.delete(4)
  mngr.wait_until_finished()
  loop.train("lo", _cfg(4), wd, {"w": jnp.zeros(3)}, _loss, jnp.ones(3), seed=0, eval_fn=_eval)
  events = read_events(os.path.join(wd, "tensorboard", "lo"))
  starts = [e.step for e in events if e.HasField("session_log") and e.session_log.status == 1]
  assert 4 in starts
