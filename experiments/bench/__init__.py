"""The benchmark and its reports: suites, the runner, result files, the pages.

It launches the library's runs (benchmark.py, ablations.py,
calibrate_frequency.py, throughput.py, step_times.py) and turns their result
files under results/ into the generated pages under docs/results/ and the
README's block (report.py, gpu_report.py, throughput_report.py,
method_table.py). It alone writes README.md, docs/results/, results/ and the
step table, and runs git (git_state.py). Run from a clone:
`python experiments/<tool>.py`, a driver per tool beside this package.
"""
