"""Leave-one-scene-out calibration of the frequency threshold on constructed grids."""
import pytest

from experiments.bench import frequency_calibration as calibration

HI = 512.0  # Hi-NeRF's L=10, s=1
POINTS = [(10, 1.0), (7, 1.0), (5, 1.0), (4, 1.0), (5, 4.0), (5, 16.0)]


def scene(criteria, psnrs):
  return {"hi_freq": HI, "grid": [{"L": L, "scale": s, "criterion": c, "psnr": p}
                                  for (L, s), c, p in zip(POINTS, criteria, psnrs)]}


def test_pick_follows_the_rule_and_regret_is_the_distance_to_the_best():
  s = scene([0.9, 0.7, 0.5, 0.3, 0.2, 0.1], [18, 19, 21, 20, 19, 17])
  assert (calibration.pick(s["grid"], 0.6, HI)["L"], calibration.regret(s["grid"], 0.6, HI)) == (5, 0)
  assert calibration.regret(s["grid"], 0.35, HI) == pytest.approx(1.0)   # picks 4:1
  # a threshold every point passes: the rule never hands back Hi's own frequency
  assert calibration.pick(s["grid"], 5.0, HI)["L"] == 7
  # none passes: the lowest frequency
  assert calibration.pick(s["grid"], 0.01, HI)["scale"] == 16.0


def test_choose_finds_the_interval_every_scene_agrees_on():
  # best point at rho 0.5 / 0.45 / 0.52: any threshold in (0.52, 0.65] picks all three
  scenes = {"a": scene([0.9, 0.7, 0.5, 0.3, 0.2, 0.1], [18, 19, 21, 20, 19, 17]),
            "b": scene([0.8, 0.65, 0.45, 0.3, 0.2, 0.1], [18, 19, 22, 20, 19, 17]),
            "c": scene([0.95, 0.75, 0.52, 0.4, 0.2, 0.1], [18, 19, 23, 21, 19, 17])}
  got = calibration.choose(scenes)
  assert 0.55 < got["threshold"] < 0.6 and got["mean_regret"] == 0.0
  loo = calibration.leave_one_out(scenes)
  assert all(r["regret"] == 0.0 for r in loo.values())
  assert loo["c"]["pick"] == (5, 1.0) and loo["c"]["best"] == (5, 1.0)


def test_leave_one_out_never_sees_the_scene_it_scores():
  # 'odd' wants a far lower threshold than the others: chosen without it, its
  # pick is the others' and its regret shows
  scenes = {"a": scene([0.9, 0.7, 0.5, 0.3, 0.2, 0.1], [18, 19, 21, 20, 19, 17]),
            "b": scene([0.8, 0.6, 0.45, 0.3, 0.2, 0.1], [18, 19, 22, 20, 19, 17]),
            "odd": scene([0.9, 0.7, 0.5, 0.3, 0.2, 0.1], [17, 18, 19, 20, 23, 18])}
  loo = calibration.leave_one_out(scenes)
  assert loo["odd"]["pick"] == (5, 1.0) and loo["odd"]["regret"] == pytest.approx(4.0)
  assert loo["odd"]["threshold"] == pytest.approx(calibration.choose(
      {k: scenes[k] for k in ("a", "b")})["threshold"])
