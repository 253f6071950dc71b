"""Many plans: problems as plain data (:mod:`.problems`), generators of problem sets
(:mod:`.problem_sets`), running them in a pool, an executor or Dask (:mod:`.runner`,
:mod:`.pool`), their results file (:mod:`.results`) and summary (:mod:`.report`)."""
import lazy_loader

# the runner (and the planner it loads) only on first use: reading or writing problems stays light
__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={"runner": ["plan_many",
                                                                                 "pending_problems"]})
