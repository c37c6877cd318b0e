"""--only: which runs of a plan a launch takes, by a regular expression on
their names (scene/method-or-variant/seed<k>)."""
import re
from typing import Callable, Iterable, List, TypeVar

T = TypeVar("T")

# A method's name may hold a '+', which a pattern must escape.
NAMING = "runs are named scene/{part}/seed<k>; a '+' in a name is escaped as \\+"


def select(runs: Iterable[T], name_of: Callable[[T], str], only: str, part: str,
           plan: str) -> List[T]:
  """The runs whose name_of(run) the regex `only` searches, in order.

  Raises ValueError, naming the flag, when `only` is not a regular expression
  or selects nothing; that message names the names' middle part ('method',
  'variant') and the plan ('suite', 'study').
  """
  try:
    pattern = re.compile(only)
  except re.error as e:
    raise ValueError(f"--only={only!r} is not a regular expression: {e}") from None
  out = [r for r in runs if pattern.search(name_of(r))]
  if not out:
    raise ValueError(f"--only={only!r} matches no run of the {plan} "
                     f"({NAMING.format(part=part)})")
  return out
