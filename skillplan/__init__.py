"""The plumbing every package of the project builds on: the root of the error hierarchy
(:mod:`skillplan.errors`), argument checks (:mod:`skillplan.validation`), command-line helpers
and safe output files (:mod:`skillplan.command_line`), progress bars (:mod:`skillplan.progress`)
and BLAS thread control (:mod:`skillplan.threads`). It imports none of ``scenes``, ``robots``,
``clamp`` or ``tlgc``."""
