"""The frequency rule (paper sec. 4.1; docs/frequency.md): Lo-NeRF's P.E.
frequency chosen per scene from how much nearby renders differ.

  spectrum     the spectrum difference rho of two images (numerics)
  view_pairs   pairs of nearby cameras per scene kind, rendered
  tuning       the search over (L, s): train a short Lo per grid point,
               pick the first whose rho passes the threshold
  calibration  the threshold, by leave-one-scene-out over a scene grid

The method that uses it is methods/halo_auto.py; its experiments are
experiments/tune_frequency.py and calibrate_frequency.py. This file imports
nothing, so each module keeps its own layer (tests/test_architecture.py).
"""
