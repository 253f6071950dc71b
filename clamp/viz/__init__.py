"""Pictures of priors and plans: figures (:mod:`.prior_plots`, :mod:`.plan_plots`), the offline
browser animation (:mod:`.animation`) and the live viewer (:mod:`.viewer`). Nothing below
this package imports it."""
