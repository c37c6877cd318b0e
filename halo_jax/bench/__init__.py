"""The benchmark and its reports: suites, the runner, result files, the pages.

The top layer beside cli/: it launches the training code's runs
(benchmark.py, ablations.py, calibrate_frequency.py, throughput.py) and turns
their result files under results/ into the generated pages under docs/results/
(report.py, gpu_report.py, throughput_report.py, method_table.py). Console
scripts: halo-bench, halo-report, halo-ablate; experiments/ holds a driver
per tool for a clone (python experiments/<tool>.py).
"""
