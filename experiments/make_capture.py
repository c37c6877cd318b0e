"""A folder of photos to try the capture path on: the built-in `textured`
scene rendered from cameras all round, written as photos alone (no poses),
as a phone or a camera would leave them.

  python -m experiments.make_capture --out=/tmp/photos      # ~5 s
  halo-train --config=capture.py:8view_cpu --config.data.root=/tmp/photos --workdir=/tmp/run

halo-train then runs structure-from-motion on them first (pycolmap).
"""
import os
import shutil
import tempfile

from absl import app, flags

from halo_jax.datasets import procedural

FLAGS = flags.FLAGS
flags.DEFINE_string("out", None, "folder to write the photos to (images/ inside it)")
flags.DEFINE_integer("num", 40, "photos")
flags.DEFINE_integer("size", 200, "their width and height in pixels")


def main(argv):
  del argv
  images = os.path.join(FLAGS.out, "images")
  os.makedirs(images, exist_ok=True)
  with tempfile.TemporaryDirectory() as tmp:
    procedural.generate(tmp, size=FLAGS.size, num_train=FLAGS.num, num_test=1, num_val=1,
                        scene="textured")
    for i in range(FLAGS.num):
      shutil.copy(os.path.join(tmp, "train", f"r_{i}.png"),
                  os.path.join(images, f"photo_{i:03d}.png"))
  print(f"{FLAGS.num} photos of {FLAGS.size}x{FLAGS.size} in {images}")


if __name__ == "__main__":
  flags.mark_flag_as_required("out")
  app.run(main)
