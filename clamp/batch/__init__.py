"""Many plans: problems as plain data (:mod:`.problems`), generators of problem sets
(:mod:`.problem_sets`), running them in a pool, an executor or Dask (:mod:`.runner`,
:mod:`.pool`), their results file (:mod:`.results`) and summary (:mod:`.report`)."""
from clamp.batch.runner import plan_many, pending_problems

__all__ = ["plan_many", "pending_problems"]
