"""Where the benchmark's files live: the clone holding this package, whose
results/ and docs/ the tools read and write (their --results and --docs flags
point elsewhere)."""
import os

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
